"""LIGGGHTS: adapter, deck, dump reader and the compiled contact-law plugin."""

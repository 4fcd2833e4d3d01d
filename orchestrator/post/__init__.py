"""Post-processing of results: summary, deposit, mass front, collapse profiles."""

"""COCD: the implicit, convex contact-dynamics engine of the erodible-bed study, on open solvers."""

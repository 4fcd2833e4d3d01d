"""The contact law of Richefeu et al. (2012) in closed form."""

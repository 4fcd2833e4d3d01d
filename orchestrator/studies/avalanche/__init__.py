"""Brick avalanches down a slope onto a board (Manzella & Labiouse 2009; Richefeu et al. 2012)."""

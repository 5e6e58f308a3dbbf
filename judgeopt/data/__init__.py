"""Demonstrations: random spline scoops run in simulation, recorded ones imported, one file format."""

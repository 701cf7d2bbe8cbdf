"""A concrete design evaluated numerically: the design itself (design), its exact figures (figures),
the worst eccentricity over the regulation range (regulation), and the derivatives of its figures
with respect to its lengths (sensitivity)."""

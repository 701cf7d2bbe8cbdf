"""Figures of a design: rocker speeds with the output envelope, drawings of the linkage, the ratio
and ripple over the regulation range. Matplotlib is imported only when a figure is drawn."""

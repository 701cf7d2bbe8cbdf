"""optdesign: sizing the converting linkages of pulse continuously variable transmissions.

Heavy modules (matplotlib, dask) are imported only by the functions that use them.
"""
__version__ = "0.1.0"

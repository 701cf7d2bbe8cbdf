"""Design atlases: the least ripple over a grid of rules (phase count, transmission angle,
pin radius, ratio floor, stroke), in lengths relative to the regulated length, so that one
atlas holds for every size of machine (the form of Hrones and Nelson, Analysis of the
Four-Bar Linkage, 1951). docs/atlas.md.

``spec`` reads the atlas file, ``run`` solves its cells (journalled, local or Dask),
``worker`` is one cell, ``table`` the csv/json, ``charts`` the figures, ``page`` the HTML.
"""

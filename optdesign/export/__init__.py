"""A design out of the tool, in forms a CAD system, a browser and a spreadsheet read.

:mod:`optdesign.export.drawing` draws the linkage to scale in mm at one crank angle as a DXF
document (through ezdxf: the pivots, joints and links on layers by role, the crank circle and
the rockers' swing arcs, a title block); :mod:`optdesign.export.svg` renders that same
document as SVG (ezdxf's drawing add-on); :mod:`optdesign.export.trajectories` tabulates every
joint's path and every output member's θ, ω and ε over a turn.
"""

"""The output driveline: imbalance and critical speed of a flexible cardan shaft.

Model of Vestnik DGTU 2017, no. 2(89), eqs. 6-18 (docs/papers.md, section 4), loaded only
when a problem file has a ``driveline:`` section:

- :mod:`optdesign.driveline.model`: the formulas, pure numpy functions in SI units;
- :mod:`optdesign.driveline.section`: the ``driveline:`` section (parsing, ``analyze``, the
  ``max_speed_fraction_of_critical`` constraint for ``solve``);
- :mod:`optdesign.driveline.plot`: the figure of y_max and D0 against the shaft speed.
"""

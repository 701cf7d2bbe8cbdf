"""Tolerance analysis of a design: Monte Carlo parts and the worst case over the tolerance box
(docs/tolerance.md)::

    from optdesign.tolerance.montecarlo import monte_carlo
    from optdesign.tolerance.worst_case import worst_case

Nothing is imported here: the ``tolerances:`` section's parser
(:mod:`optdesign.tolerance.section`), read with every problem file that has one, stays light.
"""

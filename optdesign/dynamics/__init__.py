"""Drive dynamics with compliant freewheels (Ambartsumyants & Subbotina 2015, eqs. 3-4).

``section`` reads the ``dynamics:`` key of a problem file, ``model`` holds the equations of
motion, ``integrator`` the event-driven stiff integration, ``steady`` the turn-by-turn search
for the steady cycle and its figures, ``instants`` the paper's t0..t3 of a cycle, ``verdict``
what a run ended in and why (steady, stalled, not steady), ``result`` the reported record,
``plots`` the paper-style figures. Only ``optdesign simulate`` imports any of it.
"""

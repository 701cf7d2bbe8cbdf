"""The live design explorer: drag a length or a bound and watch the linkage, the output
speed, δ and the optimum move, in the browser (``optdesign explore``) and in a notebook
(``optdesign.explore``; docs/explorer.md).

* :mod:`~optdesign.explorer.bounds`: the constraints' bounds a slider moves, by file key;
* :mod:`~optdesign.explorer.snapshot`: one design evaluated exactly, and its turn;
* :mod:`~optdesign.explorer.reoptimise`: IPOPT warm-started from the design on screen;
* :mod:`~optdesign.explorer.session`: the state and the actions (no page);
* :mod:`~optdesign.explorer.front`: a finished front's points;
* :mod:`~optdesign.explorer.page`: the Panel layout (imports Panel and Bokeh);
* :mod:`~optdesign.explorer.command`: the command line's server.
"""

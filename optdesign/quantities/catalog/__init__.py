"""Every quantity of the vocabulary, one module each: adding a module here adds a quantity to
solve, pareto, analyze, tolerance and the reports."""

"""Calls of CasADi functions at many inputs at once: NumPy lanes (lanes) and bound buffers for the
exact evaluator's inner loop (buffered)."""

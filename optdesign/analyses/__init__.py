"""Analyses of a design beyond its figures: ``optdesign analyze`` (analyze), the evaluators' error
against run time (accuracy), position/velocity/acceleration analogues over a turn (curves)."""

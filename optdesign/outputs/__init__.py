"""How results leave the process: atomic files (atomic), output folders that hold one run's files
(folder, checks), the unit of every JSON key (units) and tables that show themselves (tabular)."""

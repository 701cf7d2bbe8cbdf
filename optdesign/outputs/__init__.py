"""How results leave the process: atomic files (atomic), output folders that hold one run's files
(folder, checks), the unit of every JSON key (units), tables that show themselves (tabular),
the answer printed before the figures (answer), figures drawn beside the command
(figure_process) and where a command's time goes (phases)."""

"""Jobs: what tribench measures, each through the runner into a run folder.

They measure and never analyse (the tables are :mod:`tribench.reports.tables`'),
and may import the rest of ``harness`` and every package below it."""

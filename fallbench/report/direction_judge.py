"""Where `fallbench direction authority` and `direction radius` (cli.py) import 004's judge from;
the judge itself is papers/direction_judge.py. Kept while cli.py, edited elsewhere, imports this
path."""

from fallbench.report.papers.direction_judge import authority_from_store, radius_from_store

__all__ = ["authority_from_store", "radius_from_store"]

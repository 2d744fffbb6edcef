"""The report's paper-specific parts, apart from its generic core (ranking, forest plots,
filmstrips, sweeps, statistics, pages): 002's claims and figures (claims.py, drop_figures.py),
000's landing order and reshaped falls (reshape.py), 004's direction pages and judge
(direction.py, direction_judge.py, figures_004.py). Each is chosen by what the store holds
(strategy names, columns: selection.py), never by a scenario's name."""

"""Figures: a run's results and comparisons (:mod:`.results`), a study's (:mod:`.study`)."""

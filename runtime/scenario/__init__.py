"""The scenario file contract: its schema and loading (:mod:`.schema`, docs/scenario.md) and
the limits a scenario must respect (:mod:`.limits`)."""

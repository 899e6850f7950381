"""Planners turn a query into a program: `llm` (any OpenAI-compatible endpoint) and `rules` (offline)."""

"""Perception backends behind small protocols (`base.py`); implementations register by spec kind."""

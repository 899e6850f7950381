"""Worlds and robots behind one low-level interface (`base.py`)."""

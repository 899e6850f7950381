"""Fakes shared by several test files, one module per kind: frames, perception backends, the ball world,
a loopback chat endpoint, the truth-blind world. tests/conftest.py re-exports them, so a test file imports
them either way (`from conftest import BallWorld` or `from fakes.balls import BallWorld`). A new shared fake
goes into the module of its kind here (or a new one), not into a test file or conftest.py."""

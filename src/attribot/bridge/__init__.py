"""The robot side of the attribot bridge: protocol, safety and drivers (see docs/bridge-protocol.md).

Everything here runs on the robot's computer, where the RoboMaster SDK installs only on Python 3.6 to 3.8:
every module keeps to Python 3.8 syntax and imports nothing but the standard library, numpy and the SDK
(tests/test_bridge.py parses each file with Python 3.8's grammar and scans its imports).
"""

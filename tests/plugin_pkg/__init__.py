"""A resolver package as a user would write one, for ``tests/test_plugins.py``.

Not registered by import: the tests register it through an entry point of a dist-info they write
(``torqueopt.resolvers``: ``self-motion-brake = tests.plugin_pkg.resolvers:SelfMotionBrake``).
"""

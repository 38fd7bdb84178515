"""Lecture chapters: ``chNN_topic.py`` modules whose figures are registered with ``pbanim.plotting.figure``."""

"""Figures (matplotlib, imported lazily) and the self-contained HTML report.

This is the only subpackage that imports plotting libraries.
"""

"""Helpers the tests share, kept out of the package."""

"""Helpers the tests share: harnesses, process runners, network namespaces, figure checks."""

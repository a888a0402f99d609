"""Gymnasium environments: registration of every scenario, localization and navigation."""

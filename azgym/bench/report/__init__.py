"""A run's report: its summary, ranking, table and figures.

``results`` the summary and its files, ``summary`` the shapes of the summary and of a
contender's row in it, ``table`` the ranking and the printed table, ``plots`` the figures,
``tracking`` the figures of tracks.
"""

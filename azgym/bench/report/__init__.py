"""A run's report: its summary, ranking, table and figures.

``results`` the summary and its files, ``table`` the ranking and the printed table, ``plots``
the figures, ``tracking`` the figures of tracks.
"""

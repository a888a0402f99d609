"""The leaderboard: entries made from runs, checked as an adversary's, rerun, and published.

``entries`` making an entry from a run, submitting, reading and verifying entries; ``checks``
every check on an entry; ``entry_data`` a dataset entry's log found and checked;
``entry_files`` reading what submitters write, safely; ``plugin_files`` plug-in files in results
and entries; ``board`` the published tables and ``board_page`` the sortable page; the entry
format is ``entry.schema.json``.
"""

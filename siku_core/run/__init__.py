"""The run: the time-step loop (``simulation``), its schedules, guards, restart, limits,
progress and summary, the output rules, the element state it builds, and the command line.
"""

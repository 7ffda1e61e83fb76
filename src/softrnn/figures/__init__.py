"""Figures and animations of rod data and runs (matplotlib's object API on the Agg canvas, no
pyplot): one node's trajectory (``pictures``), the rod over time (``animation``), the plots of
runs, predictions and errors (``plots``, ``evaluation``, ``dynamic``, ``calibration``), and the one
way they are made and written (``saving``: every file is written atomically). Library code here
writes files and never shows windows."""

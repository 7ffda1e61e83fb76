"""Figures and animations (matplotlib, Agg backend): datasets as pictures and animations
(``pictures``), and the plots of runs, predictions and errors (``plots``). Library code here
writes files and never shows windows."""

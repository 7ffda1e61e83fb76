"""The magnetic experiment of paper section 5 rebuilt in simulation (``experiment``: Table 1,
Fig. 12) and the same comparison on lab CSV recordings (``lab``)."""

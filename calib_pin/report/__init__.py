"""What a calibration reports: the report dict, the HTML page and the figures.

The report dict (:mod:`.build`), the HTML page (:mod:`.html`), its figures
(:mod:`.figures`) and the comparison's figures (:mod:`.comparison_figures`).
"""

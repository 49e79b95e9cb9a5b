"""Many calibrations at once: method comparisons, benchmarks, batches, and what they share.

The methods compared on one robot (:mod:`.comparison`), the benchmark (:mod:`.benchmark`,
:mod:`.benchmark_figaroh`), a batch of measurement files (:mod:`.batch`), and what they
share: parallel workers (:mod:`.parallel`) and resumable checkpoints (:mod:`.checkpoint`).
"""

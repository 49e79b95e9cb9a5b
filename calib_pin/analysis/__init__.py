"""What the measurements can tell: identifiability, uncertainty, pose planning and metrics.

The identifiable directions of the parameters (:mod:`.identifiability`, :mod:`.subspace`),
their uncertainty (:mod:`.uncertainty`), pose planning that makes them identifiable
(:mod:`.planning`) and the error metrics (:mod:`.metrics`).
"""

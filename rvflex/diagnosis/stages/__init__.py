"""The stages of a diagnosis, in data-flow order, each a module whose ``run`` takes the previous stage's value
and returns its own (:func:`rvflex.diagnosis.fit.diagnose` runs them in turn):

``bench`` (:class:`~rvflex.diagnosis.stages.bench.Request` → ``Bench``: the plan, the measured features, the
candidates these runs can test) → ``features`` (→ ``Features``: the data anchor, the baseline model, every
parameter's secants, the weights) → ``calibration`` (→ ``Calibrated``: the nominal parameters alone, the
discrepancy they leave) → ``candidates`` (→ ``Candidates``: every effect and pair fitted with them, the leaders
refined) → ``evidence`` (→ ``Evidence``: scored, checked on withheld runs, graded) → ``verdict`` (→ ``Verdict``:
the accepted effect, its ties, the sentence) → ``report`` (→ :class:`~rvflex.diagnosis.result.Diagnosis`)."""

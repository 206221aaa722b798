"""The paper's reproduction: Luding et al. (2001)'s claims, from the coarse and fine ring
profiles of its Couette cell, with verdicts (:mod:`granavg.paper.claims`), the numbers
they decide on (:mod:`granavg.paper.numbers`), what they are measured against
(:mod:`granavg.paper.verdicts`) and the report (:mod:`granavg.paper.report`). The
analysis of anyone's fields is :mod:`granavg.analysis`, which this package builds on."""

"""Studies: the avalanche and collapse set-ups, single-brick drops, and the study-kind registry."""

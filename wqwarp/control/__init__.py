"""Gait control: the paper's gait library and the batched nominal-gait controller."""

"""Gait control: the paper's gait library as data, the batched nominal-gait controller and the open-loop driver."""

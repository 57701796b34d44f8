"""Rigs from motion: a skeleton, sparse weights and bone animation recovered from a deforming mesh sequence.

Free rigid bones and weights come from Dem Bones (SSDR, `py-dem-bones`); `joints` and `hierarchy` turn them
into a connected joint tree; `connected_solve` re-fits the bone motion and weights on that tree.
"""

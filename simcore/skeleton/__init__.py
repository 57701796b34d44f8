"""Skeleton types, tokenisation and prediction."""

from simcore.skeleton.types import JointKind, Skeleton

__all__ = ["JointKind", "Skeleton"]

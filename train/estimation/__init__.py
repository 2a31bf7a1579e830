"""Estimation for users: the Python API (Estimator, Estimate), the network choice per photo,
full-resolution maps, and what sa-estimate writes."""

from train.estimation.estimator import Estimate, Estimator

__all__ = ["Estimate", "Estimator"]

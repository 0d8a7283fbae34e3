"""The priority heuristic of section 5.3 (Eq. 9), kept importable here for code written
against ``agents.priority``; it lives in the core, ``cmdp_pymunk.evaluate``."""

from cmdp_pymunk.evaluate import (
    BETAS,
    PriorityEvaluator,
    desired_position_of_first_choice,
    priority_value,
    target_attributes,
)

__all__ = ["BETAS", "PriorityEvaluator", "desired_position_of_first_choice", "priority_value",
           "target_attributes"]

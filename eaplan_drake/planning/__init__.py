"""The planner-scheduler: the Drake system and its policy seam, the shared prediction, the paper's
output MPC, the mission-feasible MPC and the NLP solver choice.
"""

"""The PenaltyBalls task: its parameters, its scene (the engine's task), the step kernel, the
observation's layout, the starts, the sand and the randomisation."""

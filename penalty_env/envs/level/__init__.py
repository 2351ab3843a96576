"""The sand-shaping task (PenaltySandLevel): its scene (the engine's task) and its height-map kernel."""

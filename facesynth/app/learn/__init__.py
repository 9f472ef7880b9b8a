"""``facesynth learn``: the robot learns its own face (babbling, self-model, inverse model)."""

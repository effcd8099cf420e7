"""The UR5 with a coupled-wrist drive chain on MuJoCo: truth, plant, records and its check."""

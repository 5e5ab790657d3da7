"""A character's body control: attention, behaviour selection, patrol and the controllers
that turn a choice into forces (gait, gaze, posture, arms, breathing)."""

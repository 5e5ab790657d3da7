"""Point-mass physics: Verlet integration, constraint projection, collisions, the sense of impact."""

"""pybullet worlds that play the robot: the bench spine and the quadruped."""

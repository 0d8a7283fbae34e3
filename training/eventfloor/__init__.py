"""The event floor's calibration and validation, fitted and checked on the pymunk floor: they
play floors with the agents on the run machinery's backends, so they live on the training side;
the calibration as data and the event floor itself are ``cmdp_pymunk.eventfloor``."""

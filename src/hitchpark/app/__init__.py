"""Applications above the maneuver: reproducing the paper, saving reports, running many maneuvers."""

"""A useless third-party observer for ftc_mj: a benchmark that ranks it above chance is not measuring methods."""

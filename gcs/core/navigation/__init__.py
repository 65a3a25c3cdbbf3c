"""A vehicle's own navigation: feng2019's switching Kalman filter fusing INS, GPS and route segments."""

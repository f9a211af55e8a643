"""What acts on the plant and the sensors: plant terms, time profiles, actuator faults, sensor effects, and
the random streams they draw from."""

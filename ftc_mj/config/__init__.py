"""Configuration building blocks, a leaf of the package (it imports nothing else of it): the one-line input
errors, the schema's number, per-joint and joint-selection types, the safe expression language, and the
YAML loader with the ``--set`` override language."""

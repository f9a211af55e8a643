"""Method plugins: the plugin base and gain schemas, the observers and controllers, and the registry that
finds them by name (built-ins and third-party entry points)."""

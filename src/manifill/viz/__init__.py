"""Pictures and the interactive viewer."""

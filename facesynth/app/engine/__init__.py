"""The engine: what every command that runs stages shares (the embedded or joined router, so
far). Commands build on it; it imports no command."""

"""The run harness: run directories and the loops that take a method through training,
validation and test (docs/architecture.md)."""

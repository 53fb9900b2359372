"""The run harness: the loops that take a method through training, validation and test
(docs/architecture.md); the run directories' files are `cpg_suite.runfiles`'."""

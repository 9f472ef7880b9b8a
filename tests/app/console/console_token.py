"""The token the console tests start their console with (a module of its own: two test
folders have a ``conftest``, so ``from conftest import`` may find the other one)."""

TOKEN = "test-token"

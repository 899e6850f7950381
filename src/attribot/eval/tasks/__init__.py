"""The suite's tasks, one module per kind of scene; each registers its tasks with `register_task`."""

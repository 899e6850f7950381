"""The sandboxed program runner: a separate, killable process that reaches the API only over a pipe."""

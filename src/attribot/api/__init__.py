"""What LLM-written programs see: `ImagePatch` and `Robot`. The prompt is generated from these classes."""

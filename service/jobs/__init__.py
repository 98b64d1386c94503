"""Jobs: the store (the source of truth), the compute backends, and the manager between them."""

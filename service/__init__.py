"""evomesh service: the HTTP API, job store and workers, formats, viewer and command line."""

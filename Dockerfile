# syntax=docker/dockerfile:1
# Build: docker build -t evomesh .    Run: docker run -p 8000:8000 -v evomesh-data:/data evomesh
FROM python:3.11-slim AS build
WORKDIR /src
COPY pyproject.toml README.md LICENSE ./
COPY engine ./engine
COPY service ./service
RUN pip wheel --no-cache-dir --wheel-dir /wheels '.[dask]'

FROM python:3.11-slim
ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    NUMBA_CACHE_DIR=/opt/numba-cache \
    EVOMESH_DATA_DIR=/data
COPY --from=build /wheels /wheels
RUN pip install --no-cache-dir /wheels/*.whl && rm -rf /wheels \
    && useradd --create-home --uid 10001 evomesh \
    && mkdir -p /data "$NUMBA_CACHE_DIR" \
    # Compile the numba kernels once, at build time, into a cache every user can read.
    && python -c "import engine; engine.warmup()" \
    && chown -R evomesh:evomesh /data && chmod -R a+rX "$NUMBA_CACHE_DIR"
USER evomesh
WORKDIR /home/evomesh
VOLUME ["/data"]
EXPOSE 8000
HEALTHCHECK --interval=30s --timeout=5s --start-period=20s --retries=3 \
    CMD python -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/health', timeout=4)" || exit 1
CMD ["evomesh", "serve", "--host", "0.0.0.0"]

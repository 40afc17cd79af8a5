# Debian stack of cosserat-fsi (dolfinx 0.5.2, OpenMPI): the same steps as `make setup`.
#   docker build -t cosserat-fsi .
#   docker run --rm -v "$PWD/runs:/src/runs" cosserat-fsi run configs/schaefer_turek_2d1.yaml --out runs/schaefer_turek_2d1
FROM debian:bookworm

ENV DEBIAN_FRONTEND=noninteractive \
    OPENBLAS_NUM_THREADS=1 \
    OMP_NUM_THREADS=1 \
    MPLBACKEND=Agg \
    OMPI_ALLOW_RUN_AS_ROOT=1 \
    OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

# make itself; everything else is installed by `make setup` (apt check + apt-get, then .venv + pip).
RUN apt-get update \
 && apt-get install -y --no-install-recommends make ca-certificates \
 && rm -rf /var/lib/apt/lists/*

COPY . /src
WORKDIR /src
RUN make setup && rm -rf /var/lib/apt/lists/* /root/.cache/pip

ENTRYPOINT ["/src/.venv/bin/cosserat-fsi"]
CMD ["--help"]

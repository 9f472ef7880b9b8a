# syntax=docker/dockerfile:1
# facesynth services image. The base image is a build argument, so the image builds from a public
# Python image or from a locally made one where no registry is reachable (deploy/base-image.sh):
#   docker build --build-arg BASE_IMAGE=python:3.11-slim -t facesynth .
# The base must provide python3 (>= 3.11) with venv. EXTRAS="chain" (tracker, uvloop, face page,
# VMC, recording, certs: no scikit-learn, which only `facesynth learn` needs); EXTRAS="fast" (or
# "") builds the servo-board image
# (control, translator, features, router, status: no OpenCV, no inference runtime).
# The same file builds for linux/arm64 (a Raspberry Pi) as for linux/amd64: nothing in it is
# architecture-specific, every dependency has aarch64 wheels, and the base decides, e.g.
#   docker buildx build --platform linux/arm64 --build-arg EXTRAS=fast,face -t facesynth-board .
# or, without a registry, on a base from `deploy/base-image.sh --arch arm64` under qemu-user:
#   podman build --platform linux/arm64 \
#     --build-arg BASE_IMAGE=localhost/facesynth-base:bookworm-arm64 --build-arg EXTRAS=fast,face .
# Behind a TLS-intercepting proxy, give pip the proxy's CA, which never enters the image: as a build
# secret (docker build --secret id=pip_ca,src=/etc/ssl/certs/ca-certificates.crt .), or, for
# docker-compose v1, which cannot pass build secrets, as deploy/build-ca/ca.crt (git-ignored).
ARG BASE_IMAGE=python:3.11-slim

FROM ${BASE_IMAGE} AS build
ARG EXTRAS=chain
ENV PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1
WORKDIR /src
COPY pyproject.toml README.md LICENSE ./
COPY facesynth ./facesynth
COPY schemas ./schemas
COPY services ./services
RUN --mount=type=secret,id=pip_ca --mount=type=bind,source=deploy/build-ca,target=/build-ca \
    set -e; \
    for ca in /run/secrets/pip_ca /build-ca/ca.crt; do if [ -s "$ca" ]; then export PIP_CERT="$ca"; fi; done; \
    python3 -m venv /opt/facesynth; \
    /opt/facesynth/bin/pip install "./${EXTRAS:+[$EXTRAS]}"; \
    /opt/facesynth/bin/pip uninstall -q -y pip setuptools; \
    find /opt/facesynth/lib -depth -type d -name tests -path '*/site-packages/*' -exec rm -rf {} +; \
    /opt/facesynth/bin/facesynth --version

FROM ${BASE_IMAGE}
COPY --from=build /opt/facesynth /opt/facesynth
# The image starts as root only to step down at once (facesynth/app/container_user.py): every
# command runs as the owner of the mounted deploy folder (/etc/facesynth: the clone's owner, so
# ./recordings fills with that user's files and their certificates can be read), or without that
# mount as an unprivileged user, 10001 (numeric, so the base image needs no useradd). Home and
# working directory (where a recorder writes unless given a mounted folder) are open to either.
RUN mkdir -p /home/facesynth /data && chmod 1777 /home/facesynth /data
ENV PATH=/opt/facesynth/bin:$PATH HOME=/home/facesynth PYTHONUNBUFFERED=1
WORKDIR /data
# Healthy while this container's service holds its liveliness token on the rig's router
# (the router's own container checks that it accepts sessions instead).
HEALTHCHECK --interval=15s --timeout=10s --start-period=60s --retries=3 \
    CMD ["python", "-m", "facesynth.app.container_user", "health"]
ENTRYPOINT ["python", "-m", "facesynth.app.container_user"]
CMD ["--help"]

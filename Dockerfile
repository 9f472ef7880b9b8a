# facesynth services image. The base image is a build argument so the image can be built from a
# public Python image or from a locally made one (no registry reachable):
#   docker build --build-arg BASE_IMAGE=python:3.11-slim -t facesynth .
# The base must provide python3 (>= 3.11) with pip.
ARG BASE_IMAGE=python:3.11-slim
FROM ${BASE_IMAGE}

# Which extras to install: "all" (tracker + uvloop + face page and VMC) or "" for a servo-board-only image.
ARG EXTRAS=all
ENV PYTHONUNBUFFERED=1 PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1

WORKDIR /src
COPY pyproject.toml README.md LICENSE ./
COPY facesynth ./facesynth
COPY schemas ./schemas
COPY services ./services
RUN python3 -m pip install "./[${EXTRAS}]" && facesynth --version

WORKDIR /data
ENTRYPOINT ["facesynth"]
CMD ["--help"]

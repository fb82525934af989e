# The `sdfmo` command-line tool in a small image, the one deploy/k8s/sweep-indexed-job.yaml runs
# (docs/scale.md):
#
#   docker build -t ghcr.io/sdf-multioctree/sdfmo:0.1.0 .
#   docker run --rm -v "$PWD/out:/data" ghcr.io/sdf-multioctree/sdfmo:0.1.0 sweep -o /data/demo
#
# Two stages: the release build in Rust's image, then only the binary (and the licences) on
# Debian's slim image, run as an unprivileged user (65532, the user the Kubernetes Jobs give).
# It holds no Vulkan driver: the GPU commands (`render --gpu`) are not for this image.
#
# Both base images are pinned by an exact tag and by digest: a tag can be re-pushed, a digest
# cannot. The digests are the multi-platform index digests published for these tags; the machines
# this repository is built and checked on cannot reach Docker Hub, so they were read from public
# Dockerfiles that build with them (rust's since 2026-05, Debian's dated tag likewise) and not
# fetched here. Check or move them with `docker buildx imagetools inspect TAG`; with a digest
# given, the tag is only a label and the digest is what is pulled.
#
# The compiler is the release CI builds and tests with (1.95.0). Not the workspace's
# rust-version: wgpu's dependency ordered-float 5.5 needs Rust 1.90. Its image and the runtime are
# both Debian 12 (bookworm; rust's image is from Debian's snapshot of 2026-05-18, the runtime's
# dated tag is that snapshot), so the binary links against the C library it runs with.
FROM rust:1.95.0-slim-bookworm@sha256:d7482085ff5b415f84dba5647ae71606650bdef00db7aeb69f4b3d170c3e4082 AS build
WORKDIR /src
COPY . .
# --locked: the dependency versions of Cargo.lock, which CI tests. Without the release profile's
# line tables cargo strips the debug information and keeps the symbols: about 14 MB instead of
# 76 MB (`strip --strip-debug` makes 13.7 MB of today's release build).
RUN CARGO_PROFILE_RELEASE_DEBUG=false cargo build --release --locked -p sdfmo-cli \
    && install -D -m 0755 target/release/sdfmo /out/sdfmo

FROM debian:bookworm-20260518-slim@sha256:0104b334637a5f19aa9c983a91b54c89887c0984081f2068983107a6f6c21eeb
LABEL org.opencontainers.image.title="sdfmo" \
      org.opencontainers.image.description="Triangle meshes to sparse trilinear SDF octrees (SDFMultiOctree): the sdfmo CLI" \
      org.opencontainers.image.source="https://github.com/sdf-multioctree/sdf-multioctree" \
      org.opencontainers.image.version="0.1.0" \
      org.opencontainers.image.licenses="MIT OR Apache-2.0"
RUN groupadd --gid 65532 sdfmo \
    && useradd --uid 65532 --gid 65532 --no-create-home --home-dir /nonexistent \
       --shell /usr/sbin/nologin sdfmo
COPY --from=build /out/sdfmo /usr/local/bin/sdfmo
COPY LICENSE LICENSE-MIT LICENSE-APACHE /usr/share/doc/sdfmo/
USER 65532:65532
WORKDIR /data
ENTRYPOINT ["/usr/local/bin/sdfmo"]
CMD ["--help"]

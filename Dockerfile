# wsm service image. Build: docker build -t wsm .
# Run:   docker run -p 8080:8080 -v wsm-data:/data wsm
# (No Docker engine runs on the machines this project is developed on: this file has not been
# built there. It uses only the commands the README gives for a fresh machine.)
FROM rust:1.95-bookworm AS build
WORKDIR /src
COPY . .
RUN cargo build --release --locked --bin wsm

FROM debian:bookworm-slim
RUN apt-get update \
 && apt-get install -y --no-install-recommends curl ca-certificates \
 && rm -rf /var/lib/apt/lists/* \
 && useradd --system --create-home --uid 10001 wsm \
 && mkdir -p /data && chown wsm:wsm /data
COPY --from=build /src/target/release/wsm /usr/local/bin/wsm
USER wsm
VOLUME ["/data"]
EXPOSE 8080
# Set WSM_API_TOKEN to require a bearer token on mutating endpoints.
HEALTHCHECK --interval=30s --timeout=5s --start-period=10s --retries=3 \
  CMD curl -fsS http://127.0.0.1:8080/healthz || exit 1
ENTRYPOINT ["wsm"]
CMD ["serve", "--addr", "0.0.0.0:8080", "--db", "/data/wsm.db"]

# Build and run wsm in a container (the binary is self-contained; scenes are bundled).
FROM rust:1.95-bookworm AS build
WORKDIR /src
COPY . .
RUN cargo build --release --locked

FROM debian:bookworm-slim
COPY --from=build /src/target/release/wsm /usr/local/bin/wsm
ENTRYPOINT ["wsm"]
CMD ["example", "--list"]

# snell: `make demo` renders the default scene; `make test` runs every test.
# Both install the system packages they need (Debian 12: libembree-dev, libclang-dev).
SHELL := /bin/bash
CARGO ?= cargo
DEMO_SCENE ?= scenes/three_spheres.toml
DEMO_OUT ?= out/demo.png
APT_PACKAGES := libembree-dev libclang-dev
# Where cargo puts what it builds (CARGO_TARGET_DIR when it is set).
TARGET_DIR ?= $(or $(CARGO_TARGET_DIR),target)
SNELL_BIN ?= $(TARGET_DIR)/release/snell

.PHONY: deps demo test build bench fmt lint clean fuzz check-memory openjd bench-peers bench-grin

# Probes for exactly what the build loads: Embree's header and libembree3.so, and
# the libclang that bindgen (clang-sys) opens: libclang.so or libclang-<version>.so*.
# libclang-cpp.so (the stock image's libclang-cpp14) is a different library and
# does not count.
deps:
	@any() { for f in "$$@"; do [ -e "$$f" ] && return 0; done; return 1; }; \
	missing=""; \
	if [ -n "$$EMBREE_DIR" ] && [ -f "$$EMBREE_DIR/include/embree3/rtcore.h" ]; then :; \
	elif [ -f /usr/include/embree3/rtcore.h ] && any /usr/lib/*/libembree3.so /usr/lib/libembree3.so /usr/local/lib/libembree3.so; then :; \
	else missing="$$missing libembree-dev"; fi; \
	if [ -n "$$LIBCLANG_PATH" ] && any "$$LIBCLANG_PATH"/libclang.so* "$$LIBCLANG_PATH"/libclang-[0-9]*.so*; then :; \
	elif any /usr/lib/llvm-*/lib/libclang.so /usr/lib/llvm-*/lib/libclang-[0-9]*.so* /usr/lib/*/libclang.so /usr/lib/*/libclang-[0-9]*.so*; then :; \
	else missing="$$missing libclang-dev"; fi; \
	if [ -n "$$missing" ]; then \
	  echo "snell: installing missing system packages:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then \
	    export DEBIAN_FRONTEND=noninteractive; apt-get update && apt-get install -y $$missing || exit 1; \
	  elif command -v sudo >/dev/null 2>&1; then \
	    sudo apt-get update && sudo DEBIAN_FRONTEND=noninteractive apt-get install -y $$missing || exit 1; \
	  else \
	    echo "snell: not root and no sudo. Run as root: apt-get update && apt-get install -y$$missing"; exit 1; \
	  fi; \
	fi

build: deps
	$(CARGO) build --release --locked

demo: build
	@mkdir -p $(dir $(DEMO_OUT))
	$(SNELL_BIN) render $(DEMO_SCENE) -o $(DEMO_OUT) --quiet
	@echo "snell: demo image written to $(abspath $(DEMO_OUT))"

# The core library builds without the command line's dependencies (clap,
# ctrlc, indicatif, plotters): checked here so that CI keeps it so.
# No incremental cache: a one-off build does not reuse it, and it doubles the
# disk the optimised test build takes.
test: export CARGO_INCREMENTAL = 0
test: deps openjd
	$(CARGO) test --workspace --locked
	$(CARGO) build -p snell --lib --no-default-features --locked
	$(MAKE) --no-print-directory test-python

# openjd-cli (Open Job Description) in a venv for tests/farm.rs and docs/farm.md.
# Debian's python3 needs python3-venv for `python3 -m venv`: installed when missing.
OPENJD_VENV ?= .venv
OPENJD_CLI ?= openjd-cli>=0.8,<0.9
openjd: $(OPENJD_VENV)/bin/openjd

$(OPENJD_VENV)/bin/openjd:
	@missing=""; \
	command -v python3 >/dev/null 2>&1 || missing="python3"; \
	if [ -z "$$missing" ] && ! python3 -c 'import ensurepip, venv' >/dev/null 2>&1; then missing="python3-venv"; fi; \
	if [ "$$missing" = python3 ]; then missing="python3 python3-venv"; fi; \
	if [ -n "$$missing" ]; then \
	  echo "snell: installing missing system packages: $$missing (for the openjd-cli venv)"; \
	  if [ "$$(id -u)" = 0 ]; then \
	    export DEBIAN_FRONTEND=noninteractive; apt-get update && apt-get install -y $$missing || exit 1; \
	  elif command -v sudo >/dev/null 2>&1; then \
	    sudo apt-get update && sudo DEBIAN_FRONTEND=noninteractive apt-get install -y $$missing || exit 1; \
	  else \
	    echo "snell: not root and no sudo. Run as root: apt-get update && apt-get install -y $$missing"; exit 1; \
	  fi; \
	fi
	rm -rf $(OPENJD_VENV)
	python3 -m venv $(OPENJD_VENV)
	$(OPENJD_VENV)/bin/pip install --quiet --disable-pip-version-check '$(OPENJD_CLI)'
	$(OPENJD_VENV)/bin/openjd --version

# Embree FFI tests and a small render under valgrind memcheck: no invalid reads
# or writes, no definite leaks from snell's side (TBB's thread pools and
# Embree's allocator caches show up as "still reachable", not as errors).
check-memory: deps
	@command -v valgrind >/dev/null || { [ "$$(id -u)" = 0 ] && apt-get install -y valgrind; }
	$(CARGO) test --locked --test embree_ffi --no-run
	valgrind --error-exitcode=3 --leak-check=full --errors-for-leak-kinds=definite \
	  $$(ls -t $(TARGET_DIR)/debug/deps/embree_ffi-* | grep -v '\.d$$' | head -1) --test-threads=1
	$(CARGO) build --locked
	valgrind --error-exitcode=3 --leak-check=full --errors-for-leak-kinds=definite \
	  $(TARGET_DIR)/debug/snell render scenes/glass_of_water_nested.toml -o /tmp/snell-memcheck.png --width 16 --height 12 --spp 1 --threads 1 --quiet

fuzz: build
	$(SNELL_BIN) fuzz --cases 100000

bench: deps
	$(CARGO) bench --locked

# The peer race (docs/peers.md): snell against Mitsuba 3 (from PyPI, in
# PEERS_VENV, with Debian's libllvm19 for its llvm_* variants) on the three
# reference scenes, equal spp and threads, images checked by block means.
# Options through PEERS_ARGS: make bench-peers PEERS_ARGS='--reps 5 --json peers.json'
PEERS_VENV ?= .venv-peers
PEERS_MITSUBA ?= mitsuba==3.9.1
PEERS_NUMPY ?= numpy>=1.24,<3
PEERS_ARGS ?=
bench-peers: build
	@llvm=$$(bench/peers/setup.sh '$(PEERS_VENV)' '$(PEERS_MITSUBA)' '$(PEERS_NUMPY)') || exit 1; \
	echo "bench-peers: DRJIT_LIBLLVM_PATH=$$llvm"; \
	DRJIT_LIBLLVM_PATH="$$llvm" $(PEERS_VENV)/bin/python bench/peers/bench_peers.py --snell '$(SNELL_BIN)' $(PEERS_ARGS)

# Every curved-ray scene against its no-field twin (docs/grin.md, "Every
# curved-ray scene against its twin"): each scene's own film, one thread, 5
# interleaved repetitions (over an hour on 2 cores: hot_road_air takes
# minutes a render). The table replaces the one between the markers in
# GRIN_DOC. Options through GRIN_ARGS: make bench-grin GRIN_ARGS='--reps 3 --scale 0.25'
GRIN_ARGS ?=
GRIN_DOC ?= docs/grin.md
bench-grin: build
	grep -q '<!-- bench-grin:begin -->' '$(GRIN_DOC)' && grep -q '<!-- bench-grin:end -->' '$(GRIN_DOC)'
	$(SNELL_BIN) bench grin $(GRIN_ARGS) --markdown '$(GRIN_DOC).table'
	awk -v t='$(GRIN_DOC).table' '/<!-- bench-grin:end -->/ { skip = 0 } !skip { print } /<!-- bench-grin:begin -->/ { while ((getline l < t) > 0) print l; skip = 1 }' '$(GRIN_DOC)' > '$(GRIN_DOC).tmp'
	mv '$(GRIN_DOC).tmp' '$(GRIN_DOC)'
	rm -f '$(GRIN_DOC).table' '$(GRIN_DOC).tmp'

fmt:
	$(CARGO) fmt --all

lint: deps
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --all-targets --locked -- -D warnings
	$(CARGO) clippy -p snell --lib --no-default-features --locked -- -D warnings

clean:
	$(CARGO) clean
	rm -rf $(OPENJD_VENV)

# The Python package `snell` (python/): maturin (from PyPI, into the project's
# venv with numpy and pytest) builds an abi3 wheel and pip installs it.
# `make python` builds it optimised (the release profile); `make test` builds
# it in the dev profile into target/debug beside `cargo test`'s artifacts, so
# the dependencies compiled for the tests are not compiled again, then runs
# python/tests with pytest.
PYTHON_VENV ?= $(OPENJD_VENV)
PYTHON_TOOLS ?= 'maturin>=1.7,<2' 'numpy>=1.21' 'pytest>=7'
PYTHON_TARGET_DIR ?= $(TARGET_DIR)
PYTHON_PROFILE ?= release
.PHONY: python test-python lint-python bench-python
python: deps openjd
	$(PYTHON_VENV)/bin/pip install --quiet --disable-pip-version-check $(PYTHON_TOOLS)
	rm -f $(PYTHON_TARGET_DIR)/wheels/snell-*.whl
	$(PYTHON_VENV)/bin/maturin build --profile $(PYTHON_PROFILE) --locked --compatibility linux \
	  --manifest-path python/Cargo.toml --interpreter $(PYTHON_VENV)/bin/python \
	  --target-dir $(PYTHON_TARGET_DIR) --out $(PYTHON_TARGET_DIR)/wheels
	$(PYTHON_VENV)/bin/pip install --quiet --disable-pip-version-check --force-reinstall --no-deps $(PYTHON_TARGET_DIR)/wheels/snell-*.whl

test-python:
	$(MAKE) --no-print-directory python PYTHON_PROFILE=dev
	$(PYTHON_VENV)/bin/python -m pytest python/tests -q

# The binding's overhead against the CLI and the Rust warp bench, all release
# builds (python/benchmarks/overhead.py; the wheel replaces test-python's).
bench-python: build
	$(MAKE) --no-print-directory python PYTHON_PROFILE=release
	$(CARGO) bench --bench warp --no-run --locked
	$(PYTHON_VENV)/bin/python python/benchmarks/overhead.py --snell $(SNELL_BIN) $(OVERHEAD_ARGS)

# fmt and clippy on the binding crate (its own workspace, so `make lint` does not see it).
lint-python: deps
	$(CARGO) fmt --manifest-path python/Cargo.toml -- --check
	$(CARGO) clippy --manifest-path python/Cargo.toml --all-targets --locked --target-dir $(abspath $(PYTHON_TARGET_DIR)) -- -D warnings

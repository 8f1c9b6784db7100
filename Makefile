# ivoct — the user's entry point.  CMake does the building; this file only
# chains the steps so that `make demo` and `make test` work on a fresh machine.
#
#   make deps     install missing Debian packages (scripts/deps.txt)
#   make build    Release build with gcc in build/release (CLI: build/release/cli/ivoct)
#   make asan     clang + AddressSanitizer/UBSan build in build/asan, with the fuzz targets
#   make test     both builds, then every test in both
#   make fuzz     the asan build, then each fuzz target for FUZZ_TIME seconds (tests/fuzz/)
#   make demo     build, then run scripts/demo.sh (outputs in out/)
#   make bench    build, then bench/run.sh (under 30 min; make bench-quick: ~2 min)
#   make install  install into $(PREFIX) (default /usr/local)
#   make clean    remove build/ and out/

PREFIX ?= /usr/local
JOBS   ?= 2

RELEASE_DIR := build/release
ASAN_DIR    := build/asan
RELEASE_CONFIGURE := cmake -S . -B $(RELEASE_DIR) -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=gcc
ASAN_CONFIGURE    := cmake -S . -B $(ASAN_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo \
                     -DCMAKE_C_COMPILER=clang -DIVOCT_SANITIZE=ON -DIVOCT_FUZZ=ON

# Leaks are errors; any sanitizer report stops the test with a stack trace.
# IVOCT_ASAN=1 tells tests they run instrumented (to scale down heavy cases).
ASAN_ENV := IVOCT_ASAN=1 ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
            UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1

.PHONY: all deps build asan test fuzz demo bench bench-quick install clean

all: build

deps:
	bash scripts/install-deps.sh

build: deps
	$(RELEASE_CONFIGURE)
	cmake --build $(RELEASE_DIR) -j$(JOBS)

asan: deps
	$(ASAN_CONFIGURE)
	cmake --build $(ASAN_DIR) -j$(JOBS)

# Both test runs always happen; the target fails if either failed.
test: build asan
	@status=0; \
	echo "== tests: release build"; \
	ctest --test-dir $(RELEASE_DIR) --output-on-failure -j$(JOBS) || status=1; \
	echo "== tests: asan build"; \
	env $(ASAN_ENV) ctest --test-dir $(ASAN_DIR) --output-on-failure -j$(JOBS) || status=1; \
	exit $$status

# Each target in turn (nice'd) for FUZZ_TIME seconds, its corpus kept in
# build/asan/tests/fuzz/work/NAME/corpus; a crash stops that target and fails this one.
FUZZ_TIME    ?= 120
FUZZ_TARGETS ?= expr scene ivo vtk vdb
FUZZ_WORK    := $(ASAN_DIR)/tests/fuzz/work
fuzz: asan
	@status=0; \
	for t in $(FUZZ_TARGETS); do \
	    echo "== fuzz_$$t: $(FUZZ_TIME) s"; \
	    env $(ASAN_ENV) IVOCT_SOURCE_DIR=$(CURDIR) IVOCT_BIN=$(ASAN_DIR)/cli/ivoct \
	        IVOCT_FUZZ_WORK=$(FUZZ_WORK) nice bash tests/fuzz/run.sh run \
	        $(ASAN_DIR)/tests/fuzz/fuzz_$$t $$t $(FUZZ_TIME) $(FUZZ_WORK)/$$t/corpus || status=1; \
	done; \
	exit $$status

demo: build
	bash scripts/demo.sh $(RELEASE_DIR)/cli/ivoct

bench: build
	bash bench/run.sh

bench-quick: build
	bash bench/run.sh --quick

# The prefix is baked into ivoct.pc at configure time, hence the reconfigure.
install: deps
	$(RELEASE_CONFIGURE) -DCMAKE_INSTALL_PREFIX=$(PREFIX)
	cmake --build $(RELEASE_DIR) -j$(JOBS)
	cmake --install $(RELEASE_DIR)

clean:
	rm -rf build out

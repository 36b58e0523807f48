# hdnet: plain Makefile. `make` builds libhdnet.a and the hdnet tool; `make test` runs every test;
# `make check` runs the tests under AddressSanitizer + UndefinedBehaviorSanitizer; `make fuzz` runs
# the libFuzzer targets of tests/fuzz/ (FUZZ_SECONDS each); `make bench`
# prints the benchmark figures; `make demo` runs the main job on the bundled examples.

CC      ?= cc
PREFIX  ?= /usr/local
ARCH    ?= -march=x86-64-v3
OPT     ?= -O2
CFLAGS  ?= $(OPT) $(ARCH)
CFLAGS  += -std=c11 -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE -Wall -Wextra -fopenmp -Iinclude -Isrc
LDLIBS  += -lpng -ljpeg -lz -lcjson -lopenblas -lm -fopenmp -lpthread
# The library's version: the one in include/hdnet.h (HDNET_VERSION_MAJOR/MINOR/PATCH).
VERSION := $(shell sed -n 's/^\#define HDNET_VERSION_[A-Z]* \([0-9]*\).*/\1/p' include/hdnet.h | paste -sd.)
MAJOR   := $(firstword $(subst ., ,$(VERSION)))

# The default goal (its recipe is below).
all:

# The Debian/Ubuntu packages the build needs (through sudo unless already root): the "deps" set of
# debian-packages.txt, the one list .ci/run installs too.
debian_packages = $(shell awk '!/^\#/ && $$2 == "$(1)" { print $$1 }' debian-packages.txt)
DEPS := $(call debian_packages,deps)
deps:
	@if dpkg -s $(DEPS) >/dev/null 2>&1; then echo "deps: all installed"; else \
	    SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
	    $$SUDO apt-get update && $$SUDO apt-get install -y --no-install-recommends $(DEPS); fi

clean:
	rm -rf build build-check build-portable build-tsan build-fuzz hdnet

# oneDNN is the fast convolution path; `make HD_DNNL=0` builds the portable path only. Unless
# HD_DNNL is given, it is decided when something is built, not when make reads this file: every
# goal re-runs make with HD_DNNL set from whether oneDNN's header is there at that moment, after
# `deps` (when it is among the goals) has installed it. So `make deps demo` on a fresh machine
# gives the oneDNN build.
ifeq ($(origin HD_DNNL),undefined)
HD_DNNL_NOW = $$(test -f /usr/include/dnnl.h && echo 1 || echo 0)
GOALS := $(filter-out deps clean,$(or $(MAKECMDGOALS),all))
ifneq ($(GOALS),)
$(GOALS): $(filter deps,$(MAKECMDGOALS))
	@$(MAKE) --no-print-directory HD_DNNL=$(HD_DNNL_NOW) $@
endif
# One goal at a time here (each sub-make still runs -j): two goals building one folder at once
# would race.
.NOTPARALLEL:
.PHONY: $(GOALS) deps clean
else
ifeq ($(HD_DNNL),1)
ifeq ($(wildcard /usr/include/dnnl.h),)
$(error HD_DNNL=1 but oneDNN's header /usr/include/dnnl.h is missing: run `make deps`, or build the portable path with `make HD_DNNL=0`)
endif
CFLAGS  += -DHD_HAVE_DNNL=1
LDLIBS  += -ldnnl
endif
# Position-independent objects: the same ones make libhdnet.a and libhdnet.so.
CFLAGS  += -fPIC

# Open MPI makes `mpirun -np R hdnet train` data-parallel (docs/scaling.md); the tool alone links
# it, the library knows nothing of MPI. `make HD_MPI=0` builds without it.
HD_MPI  ?= $(shell command -v mpicc >/dev/null 2>&1 && echo 1 || echo 0)
ifeq ($(HD_MPI),1)
MPI_CFLAGS := -DHD_HAVE_MPI=1 $(shell mpicc --showme:compile)
MPI_LIBS   := $(shell mpicc --showme:link)
endif

# FFmpeg's libraries give video files (src/video/clip_ffmpeg.c); without them a clip is a folder of
# frames and video files are refused with a message saying what to install. `make HD_FFMPEG=0` to leave them out.
FFMPEG_PC := libavformat libavcodec libswscale libavutil
HD_FFMPEG ?= $(shell pkg-config --exists $(FFMPEG_PC) 2>/dev/null && echo 1 || echo 0)
ifeq ($(HD_FFMPEG),1)
CFLAGS  += -DHD_HAVE_FFMPEG=1 $(shell pkg-config --cflags $(FFMPEG_PC))
LDLIBS  += $(shell pkg-config --libs $(FFMPEG_PC))
endif

# libmicrohttpd is the HTTP server of `hdnet serve`; without it the command says how to get it.
HD_MHD  ?= $(shell test -f /usr/include/microhttpd.h && echo 1 || echo 0)

BUILD   ?= build
SRC     := $(sort $(wildcard src/*/*.c))
OBJ     := $(SRC:%.c=$(BUILD)/%.o)
TOOLSRC := $(sort $(wildcard tools/*.c))
TOOLOBJ := $(TOOLSRC:%.c=$(BUILD)/%.o)
SERVESRC := $(sort $(wildcard tools/serve/*.c))
PAGE    := $(sort $(wildcard tools/serve/page/*))
ifeq ($(HD_MHD),1)
CFLAGS  += -DHD_HAVE_MHD=1
TOOLOBJ += $(SERVESRC:%.c=$(BUILD)/%.o) $(BUILD)/serve_assets.o
TOOLLIBS += -lmicrohttpd
endif
TESTSRC := $(sort $(wildcard tests/test_*.c))
TESTBIN := $(TESTSRC:tests/%.c=$(BUILD)/tests/%)
# Every object and test depends on the headers it includes (gcc -MMD -MP writes BUILD/...d beside it).
# The .d names the target both relative to here and absolute: `make test` builds again with
# BUILD=/abs/path (tests/install.sh), and a .d naming only that path left a later `make` with
# the relative BUILD blind to header changes (stale objects linked against a changed struct).
DEPFLAGS = -MMD -MP -MT $(patsubst $(CURDIR)/%,%,$(abspath $@)) -MT $(abspath $@)

all: hdnet $(BUILD)/libhdnet.so

# What the objects were compiled with; rewritten only when it changes, so that switching HD_DNNL,
# CFLAGS or the compiler in one BUILD folder recompiles everything.
$(BUILD)/build.cfg: FORCE
	@mkdir -p $(dir $@)
	@echo '$(CC) $(CFLAGS) $(LDLIBS) $(MPI_CFLAGS)' > $@.tmp; if cmp -s $@.tmp $@; then rm $@.tmp; else mv $@.tmp $@; fi

# The install prefix compiled into the data lookup (src/core/data_path.c), likewise.
$(BUILD)/prefix.cfg: FORCE
	@mkdir -p $(dir $@)
	@echo '$(PREFIX)' > $@.tmp; if cmp -s $@.tmp $@; then rm $@.tmp; else mv $@.tmp $@; fi
$(BUILD)/src/core/data_path.o: $(BUILD)/prefix.cfg
CFLAGS_src/core/data_path.c = -DHD_DATADIR='"$(PREFIX)/share/hdnet"'

# ./hdnet points at the default build only (other BUILD folders leave it alone).
hdnet: $(BUILD)/hdnet
	if [ "$(BUILD)" = build ]; then ln -sf build/hdnet hdnet; fi

$(BUILD)/libhdnet.a: $(OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^

# The shared library: real name libhdnet.so.VERSION, soname libhdnet.so.MAJOR, and the two links.
# It exports exactly the functions include/hdnet.h declares: a linker version script made from the
# preprocessed header lists them, every other symbol stays internal (tests/exports.sh). The static
# library keeps everything (the tool, the tests and the benchmarks use the internal API).
$(BUILD)/libhdnet.so.$(VERSION): $(OBJ) $(BUILD)/hdnet.map
	$(CC) -shared -Wl,-soname,libhdnet.so.$(MAJOR) -Wl,--version-script=$(BUILD)/hdnet.map -o $@ $(OBJ) $(LDFLAGS) $(LDLIBS)
$(BUILD)/hdnet.map: include/hdnet.h
	@mkdir -p $(dir $@)
	{ echo '{ global:'; $(CC) -E -P -Iinclude $< | tr '\n' ' ' | grep -o 'hd_[a-z0-9_]* *(' | tr -d ' (' | sort -u | \
	    sed 's/.*/    &;/'; echo '  local: *; };'; } > $@.tmp && mv $@.tmp $@
$(BUILD)/libhdnet.so: $(BUILD)/libhdnet.so.$(VERSION)
	ln -sf libhdnet.so.$(VERSION) $(BUILD)/libhdnet.so.$(MAJOR) && ln -sf libhdnet.so.$(VERSION) $@

# A build folder from before the .d files is rebuilt once (the stamp is newer than its objects).
$(BUILD)/.deps-mmd:
	@mkdir -p $(dir $@)
	touch $@

$(BUILD)/%.o: %.c $(BUILD)/.deps-mmd $(BUILD)/build.cfg
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(CFLAGS_$<) $(DEPFLAGS) -I$(BUILD) -c $< -o $@

# Only the tool sees MPI. `private`: a target-specific value is otherwise inherited by the target's
# prerequisites, so build.cfg was written with the MPI flags when a tool object reached it first and
# without them otherwise, and every other `make` recompiled everything.
$(TOOLOBJ): private CFLAGS += $(MPI_CFLAGS)

# Only the dispatcher includes the generated command list.
$(BUILD)/tools/main.o: $(BUILD)/commands.inc

# The page of `hdnet serve`, compiled into the binary.
$(BUILD)/serve_assets.c: $(PAGE) tools/serve/embed.sh
	@mkdir -p $(dir $@)
	sh tools/serve/embed.sh $@ $(PAGE)

$(BUILD)/serve_assets.o: $(BUILD)/serve_assets.c $(BUILD)/.deps-mmd
	$(CC) $(CFLAGS) $(DEPFLAGS) -Itools -c $< -o $@

# Every tools/cmd_*.c registers itself with a line CLI_COMMAND("name", fn, "summary").
$(BUILD)/commands.inc: $(TOOLSRC)
	@mkdir -p $(dir $@)
	cat /dev/null $(wildcard tools/cmd_*.c) | grep -E '^CLI_COMMAND\(' > $@.tmp; cmp -s $@.tmp $@ && rm $@.tmp || mv $@.tmp $@

$(BUILD)/hdnet: $(TOOLOBJ) $(BUILD)/libhdnet.a
	$(CC) -o $@ $(TOOLOBJ) $(BUILD)/libhdnet.a $(LDFLAGS) $(LDLIBS) $(MPI_LIBS) $(TOOLLIBS)

$(BUILD)/tests/%: tests/%.c $(BUILD)/libhdnet.a $(BUILD)/.deps-mmd
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(DEPFLAGS) -MF $@.d -Itests -I$(BUILD) -o $@ $< $(BUILD)/libhdnet.a $(LDFLAGS) $(LDLIBS)

$(BUILD)/tests/test_header_example: $(BUILD)/header_example.inc

# The usage example in the opening comment of include/hdnet.h, extracted so a test compiles and runs it.
$(BUILD)/header_example.inc: include/hdnet.h
	@mkdir -p $(dir $@)
	sed -n '/^ \* Example/,/^ \*\//p' $< | sed -e '1d' -e '$$d' -e 's/^ \*     //' -e 's/^ \*$$//' | grep -v '^#include' > $@.tmp && mv $@.tmp $@

# Helpers the shell tests run (tests/serve_weight.c: the check of `hdnet serve`'s weight map).
TESTHELPERS := $(BUILD)/tests/serve_weight

tests: $(TESTBIN) $(TESTHELPERS) $(BUILD)/hdnet $(BUILD)/libhdnet.so

-include $(OBJ:.o=.d) $(TOOLOBJ:.o=.d) $(TESTBIN:=.d) $(TESTHELPERS:=.d)

# Runs each C test, then each shell test (which drive the built hdnet tool), all of them, ending with
# "N passed, N failed, N skipped" (and a nonzero status if any failed).
test: tests
	@HDNET=$(abspath $(BUILD)/hdnet) BUILD=$(abspath $(BUILD)) sh tests/run.sh $(abspath $(TESTBIN))

check:
	$(MAKE) BUILD=build-check OPT="-O2 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all" \
	    LDFLAGS="-fsanitize=address,undefined" HD_CHECK=1 test

# The portable build (no oneDNN: what a machine without libdnnl-dev gets) in build-portable: every C
# test (they hold its im2col + BLAS convolutions to the same results; only the oneDNN-only nc16
# plans skip, by name) and the CLI's apply script. The other shell scripts drive the same tool
# code as `make test`'s and are left to it.
test-portable:
	$(MAKE) HD_DNNL=0 BUILD=build-portable tests
	@HDNET=$(abspath build-portable/hdnet) BUILD=$(abspath build-portable) TEST_SCRIPTS="apply_cli" \
	    sh tests/run.sh $(abspath $(TESTBIN:$(BUILD)/%=build-portable/%))

# Fault injection (docs/reliability.md): kill -9 at random moments during train, decompose and
# synth (KILLS rounds), then a full disk (a small tmpfs; skipped with a reason where it cannot be
# mounted). Minutes, so not part of `make test`; CI runs it under a timeout.
KILLS ?= 20
test-kill: hdnet
	HDNET=$(abspath $(BUILD)/hdnet) KILLS=$(KILLS) sh tests/faults/kill.sh
	HDNET=$(abspath $(BUILD)/hdnet) sh tests/faults/disk_full.sh

# Fuzzing (tests/fuzz/, docs/reliability.md): every reader of untrusted input under libFuzzer with
# ASan + UBSan, FUZZ_SECONDS each; exits 1 on any finding. Needs clang, libclang-rt-dev, libomp-dev.
FUZZ_SECONDS ?= 30
FUZZ_CFLAGS := -O1 -g -fno-omit-frame-pointer -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all
fuzz: hdnet
	@command -v clang >/dev/null 2>&1 || { echo "fuzz: clang is not installed (apt-get install clang libclang-rt-dev libomp-dev)"; exit 1; }
	$(MAKE) BUILD=build-fuzz CC=clang OPT="$(FUZZ_CFLAGS)" build-fuzz/libhdnet.a
	sh tests/fuzz/run.sh $(abspath build-fuzz) $(abspath $(BUILD)/hdnet) $(FUZZ_SECONDS) $(FUZZ_TARGETS)

print-ldlibs:
	@echo $(LDFLAGS) $(LDLIBS)

print-deps:
	@echo $(DEPS) $(TEST_DEPS)

# Data-parallel training on MPI against the single-process run (tests/mpi/train.sh), and the batch
# commands' split of their inputs across ranks (tests/mpi/batch.sh); needs mpirun and Debian's
# python3 with numpy. Slow on a busy machine: its own target, which CI calls.
test-mpi: $(BUILD)/hdnet
	@for t in batch train; do \
	    d=$$(mktemp -d "$${TMPDIR:-/tmp}/hdnet-mpi.XXXXXX") && cd "$$d" && \
	    HDNET=$(abspath $(BUILD)/hdnet) sh $(abspath tests/mpi)/$$t.sh; rc=$$?; cd /; rm -rf "$$d"; \
	    [ $$rc -eq 0 ] || exit $$rc; done

# ThreadSanitizer over tests/test_threads.c (one model and one aligner in 4 threads). With clang,
# on the portable path: oneDNN and OpenBLAS are not instrumented (OpenBLAS is kept to one thread),
# and LLVM's Archer tool makes libomp's own synchronisation visible to TSan, so OpenMP inside the
# calls is checked too.
ARCHER ?= $(firstword $(wildcard /usr/lib/llvm-*/lib/libarcher.so))
tsan:
	@command -v clang >/dev/null || { echo "tsan: clang is missing (apt-get install clang libomp-dev)"; exit 1; }
	$(MAKE) BUILD=build-tsan CC=clang HD_DNNL=0 OPT="-O1 -g -fno-omit-frame-pointer -fsanitize=thread" \
	    LDFLAGS=-fsanitize=thread build-tsan/tests/test_threads
	mkdir -p build-tsan/run && cd build-tsan/run && OMP_TOOL_LIBRARIES=$(ARCHER) OPENBLAS_NUM_THREADS=1 \
	    TSAN_OPTIONS="halt_on_error=1 exitcode=66 ignore_noninstrumented_modules=1" HDNET_TESTDATA=$(abspath tests/data) HD_CHECK=1 ../tests/test_threads

# `hdnet serve` in a real browser: Debian's chromium (/usr/bin/chromium) driven by playwright-core
# from npm (tests/browser/package-lock.json). The screenshots go to SHOT and SHOT-live (docs/img/serve.png for the docs).
SHOT ?= $(BUILD)/serve-page.png
test-browser: hdnet
	cd tests/browser && { [ -d node_modules/playwright-core ] || npm ci --no-audit --no-fund; }
	HDNET=$(abspath $(BUILD)/hdnet) node tests/browser/serve_page.mjs $(abspath $(SHOT))

# 4 clients relighting through `hdnet serve` for 30 s (wrk): errors, memory, requests/s, latency.
load-test: hdnet
	HDNET=$(abspath $(BUILD)/hdnet) sh tests/load/serve_load.sh

# What the browser and load tests need besides `make deps` (debian-packages.txt's "test-deps").
TEST_DEPS := $(call debian_packages,test-deps)
test-deps:
	@if dpkg -s $(TEST_DEPS) >/dev/null 2>&1; then echo "test-deps: all installed"; else \
	    SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
	    $$SUDO apt-get update && $$SUDO apt-get install -y --no-install-recommends $(TEST_DEPS); fi

bench: hdnet
	./hdnet bench

demo: hdnet
	sh examples/demo.sh

# The man page and the bash completion, generated from the commands' option tables.
$(BUILD)/hdnet.1: $(BUILD)/hdnet
	$(BUILD)/hdnet --man > $@.tmp && mv $@.tmp $@
$(BUILD)/hdnet.bash: $(BUILD)/hdnet
	$(BUILD)/hdnet --completion bash > $@.tmp && mv $@.tmp $@

# Installs the tool, both libraries, the header, the pkg-config file and the shipped data. The
# data lookup has PREFIX compiled in, so the library is relinked for the PREFIX given here.
LIBDIR  ?= $(PREFIX)/lib
# The Python module goes where Debian's python3 looks under the prefix (PREFIX/lib/python3.X/
# dist-packages: on sys.path for /usr/local; for another prefix, put it on PYTHONPATH).
PYDIR   ?= $(shell /usr/bin/python3 -c 'import sys; print("$(LIBDIR)/python%d.%d/dist-packages" % sys.version_info[:2])' 2>/dev/null)
install: hdnet $(BUILD)/libhdnet.so $(BUILD)/hdnet.1 $(BUILD)/hdnet.bash
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(LIBDIR)/pkgconfig $(DESTDIR)$(PREFIX)/include $(DESTDIR)$(PREFIX)/share/hdnet
	install -d $(DESTDIR)$(PREFIX)/share/man/man1 $(DESTDIR)$(PREFIX)/share/bash-completion/completions
	install -m 644 $(BUILD)/hdnet.1 $(DESTDIR)$(PREFIX)/share/man/man1/hdnet.1
	install -m 644 $(BUILD)/hdnet.bash $(DESTDIR)$(PREFIX)/share/bash-completion/completions/hdnet
	install -m 755 $(BUILD)/hdnet $(DESTDIR)$(PREFIX)/bin/hdnet
	install -m 644 $(BUILD)/libhdnet.a $(DESTDIR)$(LIBDIR)/libhdnet.a
	install -m 755 $(BUILD)/libhdnet.so.$(VERSION) $(DESTDIR)$(LIBDIR)/libhdnet.so.$(VERSION)
	ln -sf libhdnet.so.$(VERSION) $(DESTDIR)$(LIBDIR)/libhdnet.so.$(MAJOR)
	ln -sf libhdnet.so.$(VERSION) $(DESTDIR)$(LIBDIR)/libhdnet.so
	install -m 644 include/hdnet.h $(DESTDIR)$(PREFIX)/include/hdnet.h
	sed -e 's|@PREFIX@|$(PREFIX)|' -e 's|@LIBDIR@|$(LIBDIR)|' -e 's|@VERSION@|$(VERSION)|' \
	    -e 's|@LIBS@|$(subst -fopenmp,-lgomp,$(LDLIBS))|' hdnet.pc.in > $(DESTDIR)$(LIBDIR)/pkgconfig/hdnet.pc
	if [ -d models ]; then cp -r models/. $(DESTDIR)$(PREFIX)/share/hdnet/; fi
	if [ -n "$(PYDIR)" ]; then install -d $(DESTDIR)$(PYDIR)/hdnet && \
	    install -m 644 python/hdnet/__init__.py $(DESTDIR)$(PYDIR)/hdnet/__init__.py; fi

.PHONY: all hdnet tests test check test-mpi tsan bench demo install FORCE test-browser load-test test-deps fuzz print-ldlibs print-deps test-kill
.SECONDARY:
endif

// pd_control: the paper's PD position control of a motor at 1 kHz (Figs. 18-19), written only
// against urb.hpp. Every millisecond it reads MotorFeedback; the callback unwraps the encoder,
// computes u = Kp e + Kd de/dt against a 0.5-Hz sinusoid and writes MotorCommand. The loop is
// embedded in the program's own: runOnce waits until input, the library's next deadline or the next
// control tick (one wait per wake-up; a program with descriptors of its own would poll them with
// fd() and call runOnce(0), urb_loop.h). With --cyclic it is a fixed-period program instead: it
// sleeps to each tick (urb_sleep_until) and calls service(), which handles every response of the
// period without waiting: one wake-up per tick, the feedback's callback (and so the command it
// writes) up to one period later than with runOnce (urb_loop.h, urb_loop_service).
//
//     build/host_c/pd_control PORT [--seconds S] [--hz F] [--kp V/rad] [--kd Vs/rad] [--timeout-ms MS]
//                                  [--cyclic]
//     (against the hosted bridge: build/firmware/urb-bridge-hosted --node motor,0,0x20 --link /tmp/urbX)
//
// It prints what it did: cycles, late ticks, reads and commands with their outcomes, the read
// latency (submission to callback), the last position, reference and command. Exit status 0 when
// every request succeeded, 1 otherwise, 2 for a usage error. --timeout-ms sets the response timeout
// (default: the library's, 100 ms on RS232), stretches the lost-bridge silence to 5 times it and the
// gap that ends a partial response to a fifth of it (at least their defaults, 500 and 20 ms): a
// machine whose scheduler stalls the bridge longer than that sees UPLINK_TIMEOUT, correctly.
#include <signal.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "urb.hpp"

extern "C" {
#include "urb_sensorhex.h"
}

namespace {

constexpr double kCountsPerRad = URB_ENCODER_COUNTS_PER_REV / (2.0 * M_PI);
constexpr double kLimitVolts = 12.0;

struct Axis {
    urb::NodeAccessor *node = nullptr;
    double kp = 8.0, kd = 0.05, amp = 4 * M_PI, freq = 0.5;
    int64_t t0 = 0;
    bool haveRaw = false;
    uint16_t raw = 0;
    int64_t pos = 0;  // unwrapped counts
    bool havePrev = false;
    double prevE = 0.0;
    int64_t prevT = 0;
    double lastRef = 0.0, lastPos = 0.0, lastU = 0.0;
    uint64_t reads = 0, readsOk = 0, writes = 0, writesOk = 0, refusedSubmits = 0;
    uint64_t flagsSeen = 0;
    std::vector<int64_t> latencies;  // reserved at setup: the real-time path never allocates
};

void onCommand(urb::NodeRequest *req, void *user)
{
    Axis *a = static_cast<Axis *>(user);
    a->writes++;
    a->writesOk += req->ok() ? 1 : 0;
    a->flagsSeen |= req->flags();
}

void onFeedback(urb::NodeRequest *req, void *user)
{
    Axis *a = static_cast<Axis *>(user);
    a->reads++;
    a->flagsSeen |= req->flags();
    if (a->latencies.size() < a->latencies.capacity()) {
        a->latencies.push_back(req->latencyNs());
    }
    urb_motor_feedback_t fb;
    if (!req->decode(urb_motor_feedback_decode, fb)) {
        return;  // the flag says why; no retransmission (paper Sec. IV-C)
    }
    a->readsOk++;
    if (a->haveRaw) {
        a->pos += static_cast<int16_t>(static_cast<uint16_t>(fb.encoder - a->raw));
    }
    a->raw = fb.encoder;
    a->haveRaw = true;
    int64_t const t = req->submittedNs();  // the loop's instant, not the callback's
    double const pos = static_cast<double>(a->pos) / kCountsPerRad;
    double const ref = a->amp * std::sin(2 * M_PI * a->freq * static_cast<double>(t - a->t0) * 1e-9);
    double const e = ref - pos;
    double const de = a->havePrev ? (e - a->prevE) / std::max(1e-6, static_cast<double>(t - a->prevT) * 1e-9) : 0.0;
    a->prevE = e;
    a->prevT = t;
    a->havePrev = true;
    double const u = std::max(-kLimitVolts, std::min(kLimitVolts, a->kp * e + a->kd * de));
    a->lastRef = ref;
    a->lastPos = pos;
    a->lastU = u;
    urb_motor_command_t cmd{static_cast<int16_t>(std::lround(u * 1000.0))};
    urb::NodeRequest *w = a->node->newRequest();
    if ((w == nullptr) ||
        (a->node->submitRequest(&w->write(URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_COMMAND, urb_motor_command_encode, cmd)
                                     .setCallback(onCommand, a)) != URB_HOST_OK)) {
        a->refusedSubmits++;
        a->node->releaseRequest(w);
    }
}

volatile sig_atomic_t stopRequested = 0;
void onSignal(int) { stopRequested = 1; }

int usage(const char *why)
{
    std::fprintf(stderr, "pd_control: %s\nusage: pd_control PORT [--seconds S] [--hz F] [--kp V/rad] [--kd Vs/rad] "
                 "[--timeout-ms MS] [--cyclic]\n",
                 why);
    return 2;
}

}  // namespace

int main(int argc, char **argv)
{
    if (argc < 2) {
        return usage("give the bridge's port");
    }
    const char *port = argv[1];
    double seconds = 2.0, hz = 1000.0;
    Axis axis;
    urb_core_config_t link;
    urb_core_default_config(&link, URB_LINK_RS232);
    bool cyclic = false;
    for (int i = 2; i < argc; i += 2) {
        if (std::strcmp(argv[i], "--cyclic") == 0) {
            cyclic = true;
            i--;  // a flag without a value
            continue;
        }
        if (i + 1 >= argc) {
            return usage("an option lacks its value");
        }
        double const v = std::atof(argv[i + 1]);
        if (std::strcmp(argv[i], "--seconds") == 0 && v > 0) {
            seconds = v;
        } else if (std::strcmp(argv[i], "--hz") == 0 && v > 0 && v <= 10000) {
            hz = v;
        } else if (std::strcmp(argv[i], "--kp") == 0 && v >= 0) {
            axis.kp = v;
        } else if (std::strcmp(argv[i], "--kd") == 0 && v >= 0) {
            axis.kd = v;
        } else if (std::strcmp(argv[i], "--timeout-ms") == 0 && v >= 1 && v <= 60000) {
            link.timeout_ns = static_cast<urb_ns_t>(v * 1e6);
            link.lost_after_ns = std::max(link.lost_after_ns, 5 * link.timeout_ns);
            link.resync_gap_ns = std::max(link.resync_gap_ns, link.timeout_ns / 5);
        } else {
            return usage("unknown option or bad value");
        }
    }
    signal(SIGINT, onSignal);
    signal(SIGTERM, onSignal);

    // ---- setup (may allocate) ----
    urb::URBInterface *intf = urb::URBInterface::instance();
    if (intf == nullptr) {
        return usage("the URB interface could not be created");
    }
    if (intf->addBusManager(new urb::RS232Manager(port, 115200, &link)) != URB_HOST_OK) {
        std::fprintf(stderr, "pd_control: %s\n", intf->lastError());
        return 1;
    }
    axis.node = intf->findNode(URB_NODE_MOTOR_DRIVER_CLASS, 0);
    if (axis.node == nullptr) {
        std::fprintf(stderr, "pd_control: %s\n", intf->lastError());
        return 1;
    }
    std::printf("pd_control: bridge %s, MotorDriver:0 at address %u, Kp %.2f V/rad, Kd %.3f V s/rad\n", port,
                axis.node->row()->address, axis.kp, axis.kd);
    uint64_t const cycles = static_cast<uint64_t>(std::llround(seconds * hz));
    axis.latencies.reserve(cycles);
    urb_motor_config_t cfg{URB_MOTOR_MODE_VOLTAGE, 0, 0, 0, 12000};
    urb::NodeRequest *enable = axis.node->newRequest();
    axis.node->submitRequest(&enable->write(URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_CONFIG, urb_motor_config_encode, cfg));

    // ---- the 1-kHz loop (no allocation from here on) ----
    int64_t const period = static_cast<int64_t>(1e9 / hz);
    int64_t next = (urb_now_ns() / period + 1) * period;
    axis.t0 = next;
    uint64_t done = 0, late = 0;
    int64_t worstLate = 0;
    while ((done < cycles) && !stopRequested) {
        int64_t const now = urb_now_ns();
        if (cyclic) {
            urb_sleep_until(next);
            intf->service();
        } else {
            intf->runOnce((next > now) ? next - now : 0);
        }
        int64_t const t = urb_now_ns();
        if (t >= next) {
            int64_t const lateness = t - next;
            worstLate = std::max(worstLate, lateness);
            late += (lateness > period / 2) ? 1 : 0;
            urb::NodeRequest *r = axis.node->newRequest();
            if ((r == nullptr) ||
                (axis.node->submitRequest(&r->read(URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_FEEDBACK).setCallback(onFeedback, &axis)) !=
                 URB_HOST_OK)) {
                axis.refusedSubmits++;
                axis.node->releaseRequest(r);
            }
            done++;
            next += period;
            if (next <= t) {  // overslept a whole period: skip ahead, never burst
                next = (t / period + 1) * period;
            }
        }
    }
    int64_t const settle = urb_now_ns() + 200 * URB_NS_PER_MS;  // the last callbacks
    while ((axis.node->requestsInUse() > 0) && (urb_now_ns() < settle)) {
        intf->runOnce(5 * URB_NS_PER_MS);
    }

    std::vector<int64_t> lat(axis.latencies);
    std::sort(lat.begin(), lat.end());
    double const med = lat.empty() ? 0.0 : static_cast<double>(lat[lat.size() / 2]) / 1e3;
    double const p99 = lat.empty() ? 0.0 : static_cast<double>(lat[(lat.size() * 99) / 100]) / 1e3;
    double const worst = lat.empty() ? 0.0 : static_cast<double>(lat.back()) / 1e3;
    char flags[200];
    (void)urb_flags_describe(static_cast<urb_flags_t>(axis.flagsSeen), flags, sizeof flags);
    std::printf("pd_control: %llu cycles at %.0f Hz (%s), %llu late by more than half a period (worst %.0f us)\n",
                static_cast<unsigned long long>(done), hz, cyclic ? "cyclic: sleep, service" : "runOnce",
                static_cast<unsigned long long>(late),
                static_cast<double>(worstLate) / 1e3);
    std::printf("pd_control: reads %llu ok %llu, commands %llu ok %llu, not submitted %llu, flags seen %s\n",
                static_cast<unsigned long long>(axis.reads), static_cast<unsigned long long>(axis.readsOk),
                static_cast<unsigned long long>(axis.writes), static_cast<unsigned long long>(axis.writesOk),
                static_cast<unsigned long long>(axis.refusedSubmits), flags);
    std::printf("pd_control: read latency median %.0f us, 99%% %.0f us, max %.0f us\n", med, p99, worst);
    std::printf("pd_control: last position %.4f rad, reference %.4f rad, command %.3f V\n", axis.lastPos,
                axis.lastRef, axis.lastU);
    bool const allOk = (axis.reads == done) && (axis.readsOk == axis.reads) && (axis.writes == axis.readsOk) &&
                       (axis.writesOk == axis.writes) && (axis.refusedSubmits == 0);
    std::printf("pd_control: %s\n", allOk ? "every request succeeded" : "some requests failed");
    return allOk ? 0 : 1;
}

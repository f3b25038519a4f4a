// hpp_check: urb.hpp used as a program written only against it would, against a bridge on PORT
// (the hosted bridge firmware over a pty: MotorDriver:0 at 0x20), built with -fno-exceptions.
// Each check prints a line; the last line says how many passed. Exit 0 only when all did.
// Run by tests/host_c/test_example.py.
#include <cstdio>
#include <cstring>

#include "urb.hpp"

extern "C" {
#include "urb_sensorhex.h"
}

namespace {

int passed = 0;
int failed = 0;

void check(bool ok, const char *what)
{
    std::printf("%s: %s\n", ok ? "ok" : "FAILED", what);
    (ok ? passed : failed)++;
}

struct Seen {
    int calls = 0;
    urb::Flags flags = 0;
    uint16_t encoder = 0xFFFF;
    bool decoded = false;
    bool resubmitted = false;
};

void onRead(urb::NodeRequest *req, void *user)
{
    Seen *s = static_cast<Seen *>(user);
    s->calls++;
    s->flags = req->flags();
    urb_motor_feedback_t fb;
    s->decoded = req->decode(urb_motor_feedback_decode, fb);
    if (s->decoded) {
        s->encoder = fb.encoder;
    }
    if (!s->resubmitted && req->ok()) {  // a callback may submit its own request again
        s->resubmitted = true;
        (void)req->node()->submitRequest(req);
    }
}

void pump(urb::URBInterface &urb, const int &calls, int want)
{
    int64_t const end = urb_now_ns() + 2 * URB_NS_PER_S;
    while ((calls < want) && (urb_now_ns() < end)) {
        urb.runOnce(5 * URB_NS_PER_MS);
    }
}

// The same as a cyclic program: sleep to each 1-ms tick, then service() (urb_loop_service).
void serviceEachTick(urb::URBInterface &urb, const int &calls, int want)
{
    int64_t tick = (urb_now_ns() / URB_NS_PER_MS + 1) * URB_NS_PER_MS;
    int64_t const end = urb_now_ns() + 2 * URB_NS_PER_S;
    bool ran = true;
    while ((calls < want) && (urb_now_ns() < end)) {
        urb_sleep_until(tick);
        ran = ran && (urb.service() >= 0);
        tick += URB_NS_PER_MS;
    }
    check(ran, "service() runs the loop without an error");
}

}  // namespace

int main(int argc, char **argv)
{
    if (argc != 2) {
        std::fprintf(stderr, "usage: hpp_check PORT\n");
        return 2;
    }
    Seen late;  // outlives the interface: its callback runs when the interface closes
    {
        urb::URBInterface urb;
        check(urb.ok(), "an interface of its own");
        urb.setPoolSize(3);
        check(urb.addBusManager(nullptr) == URB_HOST_EINVAL, "addBusManager(nullptr) is refused");
        check(urb.addBusManager(new urb::RS232Manager("/dev/no-such-urb-port")) == URB_HOST_EIO &&
                  std::strstr(urb.lastError(), "no such port") != nullptr,
              "a missing port is said, with what to do");
        check(urb.addBusManager(new urb::RS232Manager(argv[1])) == URB_HOST_OK, "addBusManager opens and discovers");
        check(urb.findNode(URB_NODE_MOTOR_DRIVER_CLASS, 7) == nullptr &&
                  std::strstr(urb.lastError(), "no MotorDriver with index 7 was discovered") != nullptr,
              "findNode of a node not there: nullptr and why");
        check(urb.findNode("NoSuchType", 0) == nullptr, "findNode of an unknown type name");
        urb::NodeAccessor *motor = urb.findNode("motordriver", 0);
        check(motor != nullptr && motor == urb.findNode(URB_NODE_MOTOR_DRIVER_CLASS, 0),
              "findNode by name and by class give the same accessor");
        if (motor == nullptr) {
            std::printf("%d checks passed, %d failed\n", passed, failed);
            return 1;
        }
        check(motor->row()->address == 0x20 && motor->mailboxSize(true, 1) == 6, "its row and its layout");

        Seen seen;
        urb::NodeRequest *req = motor->newRequest();
        check(req != nullptr, "newRequest from the pool");
        check(motor->submitRequest(&req->read(URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_FEEDBACK).setCallback(onRead, &seen)) ==
                  URB_HOST_OK,
              "submitRequest of a read");
        check(motor->submitRequest(req) == URB_HOST_EBUSY, "a request in flight cannot be submitted again");
        pump(urb, seen.calls, 2);
        check(seen.calls == 2 && seen.flags == URB_FLAG_NONE && seen.decoded && seen.encoder == 0,
              "the callback ran once per submission, typed data decoded");
        check(motor->requestsInUse() == 0, "the pooled request went back after its last callback");

        urb::NodeRequest *a = motor->newRequest();
        urb::NodeRequest *b = motor->newRequest();
        urb::NodeRequest *c = motor->newRequest();
        check(a && b && c && motor->newRequest() == nullptr, "the pool holds 3: the 4th is nullptr, no allocation");
        motor->releaseRequest(c);
        Seen refused;
        check(motor->submitRequest(&a->read(URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_FEEDBACK, 5).setCallback(onRead, &refused)) ==
                  URB_HOST_OK,
              "a request of the wrong size is submitted");
        check(refused.calls == 0, "its refusal is not called back inside submitRequest");
        pump(urb, refused.calls, 1);
        check(refused.calls == 1 && refused.flags == URB_FLAG_HOST_SIZE_MISMATCH,
              "it is refused on the host: HOST_SIZE_MISMATCH, nothing sent");
        check(motor->submitRequest(&b->read(9)) == URB_HOST_EINVAL, "a mailbox above 7 is refused at once");
        motor->releaseRequest(b);
        char text[300];
        check(std::strstr(a->describe(text, sizeof text), "HOST_SIZE_MISMATCH: the mailbox has another size") != nullptr,
              "describe() says what the flag means");

        urb::NodeAccessor *bridge = urb.nodeAt(nullptr, 0);
        check(bridge == nullptr, "nodeAt(nullptr) is refused");
        Seen info;
        urb::NodeRequest own(motor);  // the application's own request object
        check(motor->submitRequest(&own.read(URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_STATUS).setCallback(onRead, &info)) ==
                  URB_HOST_OK,
              "a request of the application's own");
        serviceEachTick(urb, info.calls, 2);
        check(info.calls == 2 && own.ok() && own.size() == 4,
              "its outcome stays in it; serviced once per tick, it and its resubmission each came back once");

        urb::NodeRequest *last = motor->newRequest();
        motor->submitRequest(&last->read(URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_FEEDBACK).setCallback(onRead, &late));
        late.resubmitted = true;
        // the interface goes out of scope with the request in flight: its callback still runs, once
    }
    check(late.calls == 1, "closing the interface drained the request in flight: one callback");
    std::printf("%d checks passed, %d failed\n", passed, failed);
    return failed == 0 ? 0 : 1;
}

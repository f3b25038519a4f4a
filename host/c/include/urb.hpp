// urb.hpp: the URB host API in C++17, with the paper's names and shape (Saranli et al., IEEE TIM
// 2011, Sec. IV-C, Fig. 5), on the C library of urb_loop.h. Header-only; link liburbhost.
//
//     urb::URBInterface *intf = urb::URBInterface::instance();          // one per process
//     intf->addBusManager(new urb::RS232Manager("/dev/ttyS0"));         // opens, discovers
//     urb::NodeAccessor *node = intf->findNode(URB_NODE_MOTOR_DRIVER_CLASS, 0);
//     urb::NodeRequest *req = node->newRequest();                         // from the node's pool
//     req->read(URB_NODE_MOTOR_DRIVER_OUTBOX_MOTOR_FEEDBACK);             // size from the schema
//     req->setCallback(read_callback);                                    // void (*)(NodeRequest *, void *)
//     node->submitRequest(req);                                           // read_callback runs once
//     intf->startThread();   // or: poll(intf->fd()) / intf->runOnce(timeout) in your own loop,
//                            // or a cyclic program's urb_sleep_until(tick) + intf->service()
//
// Errors. Nothing here throws, in setup or in the real-time path; the header builds with
// -fno-exceptions. Setup calls return a URB_HOST_* code (or nullptr) and lastError() says what
// happened and what to do; a request's failure is its flags() (urb_flags.h), exactly one flag,
// never an exception, never retransmitted.
//
// Memory. Setup allocates (the interface's loop, ~0.25 MiB; each manager; each node's request
// pool); the real-time path never does: newRequest() takes a request from its node's fixed pool
// and the library gives it back after its callback returns (unless the callback resubmitted it).
// RAII: destroying the interface closes every bridge (draining: requests in flight get their
// answer or their timeout) and runs every callback still owed.
//
// Threads. Any thread may call newRequest/submitRequest; callbacks run on the thread that runs
// the loop (startThread's, or yours in runOnce), one at a time, in request order per bridge.
#ifndef URB_HPP
#define URB_HPP

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <new>

extern "C" {
#include "urb_loop.h"
}

namespace urb {

class NodeAccessor;
class NodeRequest;
class URBInterface;

/** A completion callback: runs exactly once per submission, on the loop's thread. The request is
 *  the application's again inside it; a pooled one returns to its pool when the callback returns
 *  unless the callback submitted it again. */
using Callback = void (*)(NodeRequest *req, void *user);

/** Flags of a completed request (urb_flags.h: URB_FLAG_NO_NODE, URB_FLAG_UPLINK_TIMEOUT, ...). */
using Flags = urb_flags_t;

// -------------------------------------------------------------------------------------------
/** One read or write of one mailbox of one node, and its outcome (the paper's NodeRequest). */
class NodeRequest {
public:
    /** A request of the application's own (on the stack, a member): it must outlive its callback.
     *  `node` (may be nullptr until submitRequest) gives read() the layout's sizes. */
    explicit NodeRequest(NodeAccessor *node = nullptr) noexcept : node_(node) { std::memset(&t_, 0, sizeof t_); }
    NodeRequest(const NodeRequest &) = delete;
    NodeRequest &operator=(const NodeRequest &) = delete;

    /** Read outbox `mbox`; size 0 (default): the size of the node's layout (a mailbox the layout
     *  lacks is refused with URB_FLAG_HOST_SIZE_MISMATCH when submitted). Returns *this; a mailbox
     *  above 7 or a size above 32 makes submitRequest return URB_HOST_EINVAL. */
    NodeRequest &read(uint8_t mbox, uint8_t size = 0) noexcept
    {
        uint8_t const n = (size != 0u) ? size : layoutSize(true, mbox);
        valid_ = urb_transfer_read(&t_, 0u, mbox, (n == 0u) ? 1u : n) == URB_HOST_OK;
        return *this;
    }

    /** Write `size` bytes (1..32, copied) to inbox `mbox`. */
    NodeRequest &write(uint8_t mbox, const void *data, uint8_t size) noexcept
    {
        valid_ = urb_transfer_write(&t_, 0u, mbox, static_cast<const uint8_t *>(data), size) == URB_HOST_OK;
        return *this;
    }

    /** Write a message with its generated encoder, e.g.
     *  write(URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_COMMAND, urb_motor_command_encode, cmd). */
    template <class M>
    NodeRequest &write(uint8_t mbox, int32_t (*encode)(const M *, uint8_t *, size_t), const M &msg) noexcept
    {
        uint8_t buf[URB_HOST_MAILBOX_MAX];
        int32_t const n = encode(&msg, buf, sizeof buf);
        if (n <= 0) {
            valid_ = false;
            return *this;
        }
        return write(mbox, buf, static_cast<uint8_t>(n));
    }

    /** The callback (and its argument) for this request; none: the node's default (setCallback). */
    NodeRequest &setCallback(Callback fn, void *user = nullptr) noexcept
    {
        fn_ = fn;
        user_ = user;
        return *this;
    }

    bool ok() const noexcept { return urb_transfer_ok(&t_); }
    Flags flags() const noexcept { return t_.flags; }
    /** The bridge's Status (0..8) when it answered, -1 otherwise. */
    int status() const noexcept { return t_.status; }
    /** The mailbox contents of a successful read (the paper's getData()), size() bytes. */
    const uint8_t *getData() const noexcept { return t_.response; }
    uint8_t size() const noexcept { return t_.response_len; }
    /** Decode the data with a generated decoder, e.g. decode(urb_motor_feedback_decode, fb). */
    template <class M> bool decode(int32_t (*fn)(M *, const uint8_t *, size_t), M &out) const noexcept
    {
        return ok() && (t_.response_len > 0u) && (fn(&out, t_.response, t_.response_len) >= 0);
    }
    /** Submission to callback, ns (the paper's latency); -1 before the callback. */
    int64_t latencyNs() const noexcept { return urb_transfer_latency_ns(&t_); }
    int64_t submittedNs() const noexcept { return t_.submitted_ns; }
    int64_t completedNs() const noexcept { return t_.completed_ns; }
    /** What went wrong and what to do ("NO_NODE: the node no longer acknowledges ..."). */
    const char *describe(char *buf, size_t n) const noexcept
    {
        char names[160];
        (void)urb_flags_describe(t_.flags, names, sizeof names);
        (void)std::snprintf(buf, n, "%s%s%s%s: %s", names, t_.lost_reason[0] ? " (" : "", t_.lost_reason,
                            t_.lost_reason[0] ? ")" : "", urb_flags_hint(t_.flags));
        return buf;
    }
    /** The C transfer underneath (read-only use). */
    const urb_transfer_t &transfer() const noexcept { return t_; }
    NodeAccessor *node() const noexcept { return node_; }

private:
    friend class NodeAccessor;
    uint8_t layoutSize(bool outbox, uint8_t mbox) const noexcept;
    static void trampoline(urb_transfer_t *t, void *self);

    urb_transfer_t t_;
    NodeAccessor *node_ = nullptr;
    Callback fn_ = nullptr;
    void *user_ = nullptr;
    NodeRequest *nextFree_ = nullptr;
    bool valid_ = false;
    bool pooled_ = false;
    bool resubmitted_ = false;
};

// -------------------------------------------------------------------------------------------
/** Access to one discovered node, as if directly attached (the paper's NodeAccessor). */
class NodeAccessor {
public:
    NodeAccessor(const NodeAccessor &) = delete;
    NodeAccessor &operator=(const NodeAccessor &) = delete;
    ~NodeAccessor() = default;

    /** A request from this node's pool (sized at setup: URBInterface::setPoolSize), or nullptr
     *  when every one is in use. O(1), no allocation, thread-safe. */
    NodeRequest *newRequest() noexcept
    {
        lockPool();
        NodeRequest *r = free_;
        if (r != nullptr) {
            free_ = r->nextFree_;
            r->nextFree_ = nullptr;
            r->fn_ = nullptr;
            r->user_ = nullptr;
            r->valid_ = false;
            std::memset(&r->t_, 0, sizeof r->t_);
        }
        unlockPool();
        return r;
    }

    /** Give back a pooled request that was never submitted (a submitted one comes back by itself). */
    void releaseRequest(NodeRequest *req) noexcept
    {
        if ((req != nullptr) && req->pooled_ && (req->node_ == this) && !urb_transfer_owned(&req->t_)) {
            lockPool();
            req->nextFree_ = free_;
            free_ = req;
            unlockPool();
        }
    }

    /** Send `req` (built with read/write); its callback runs exactly once, on the loop's thread.
     *  A request the host refuses (node gone, wrong size, other schema) gets its callback with the
     *  refusal's flag. Returns URB_HOST_OK; URB_HOST_EINVAL for nullptr or a request badly built
     *  (no callback comes then); URB_HOST_EBUSY while req is still in flight. No allocation. */
    int32_t submitRequest(NodeRequest *req) noexcept
    {
        if ((req == nullptr) || !req->valid_) {
            return URB_HOST_EINVAL;
        }
        req->node_ = this;
        req->resubmitted_ = true;
        (void)urb_transfer_set_callback(&req->t_, &NodeRequest::trampoline, req);
        int32_t const rc = urb_node_submit(&node_, &req->t_);
        if (rc != URB_HOST_OK) {
            req->resubmitted_ = false;
        }
        return rc;
    }

    /** The callback of requests that have none of their own. */
    void setCallback(Callback fn, void *user = nullptr) noexcept
    {
        fn_ = fn;
        user_ = user;
    }

    /** The size of a mailbox of this node's layout (0: none). */
    uint8_t mailboxSize(bool outbox, uint8_t mbox) const noexcept { return urb_node_mailbox_size(&node_, outbox, mbox); }
    /** Its row of the system table (class, index, address, identification, flags); nullptr for the bridge. */
    const urb_node_row_t *row() const noexcept { return urb_node_row(&node_); }
    const urb_node_t &cnode() const noexcept { return node_; }
    /** Requests in use (taken from the pool and not back yet). */
    size_t requestsInUse() const noexcept { return inUse(); }

private:
    friend class URBInterface;
    friend class NodeRequest;
    NodeAccessor() = default;

    bool init(const urb_node_t &n, size_t pool) noexcept
    {
        node_ = n;
        pool_.reset(new (std::nothrow) NodeRequest[pool]);
        if (!pool_) {
            return false;
        }
        poolSize_ = pool;
        for (size_t i = 0; i < pool; i++) {
            pool_[i].pooled_ = true;
            pool_[i].node_ = this;
            pool_[i].nextFree_ = (i + 1 < pool) ? &pool_[i + 1] : nullptr;
        }
        free_ = (pool > 0) ? &pool_[0] : nullptr;
        return true;
    }
    void lockPool() const noexcept
    {
        while (poolLock_.test_and_set(std::memory_order_acquire)) {
        }
    }
    void unlockPool() const noexcept { poolLock_.clear(std::memory_order_release); }
    size_t inUse() const noexcept
    {
        lockPool();
        size_t n = 0;
        for (NodeRequest *r = free_; r != nullptr; r = r->nextFree_) {
            n++;
        }
        unlockPool();
        return poolSize_ - n;
    }

    urb_node_t node_{};
    std::unique_ptr<NodeRequest[]> pool_;
    size_t poolSize_ = 0;
    NodeRequest *free_ = nullptr;
    mutable std::atomic_flag poolLock_ = ATOMIC_FLAG_INIT;
    Callback fn_ = nullptr;
    void *user_ = nullptr;
};

inline uint8_t NodeRequest::layoutSize(bool outbox, uint8_t mbox) const noexcept
{
    return (node_ == nullptr) ? 0u : node_->mailboxSize(outbox, mbox);
}

inline void NodeRequest::trampoline(urb_transfer_t *, void *self)
{
    NodeRequest *r = static_cast<NodeRequest *>(self);
    NodeAccessor *n = r->node_;
    r->resubmitted_ = false;
    Callback fn = (r->fn_ != nullptr) ? r->fn_ : n->fn_;
    void *user = (r->fn_ != nullptr) ? r->user_ : n->user_;
    if (fn != nullptr) {
        fn(r, user);
    }
    if (r->pooled_ && !r->resubmitted_) {
        n->releaseRequest(r);
    }
}

// -------------------------------------------------------------------------------------------
/** One bridge on one uplink (the paper's bus managers). Owned by the URBInterface it is added to. */
class BusManager {
public:
    virtual ~BusManager() = default;
    BusManager(const BusManager &) = delete;
    BusManager &operator=(const BusManager &) = delete;

    /** The port path (or name). */
    const char *name() const noexcept { return path_; }
    /** Why its bridge is lost, nullptr while usable. */
    const char *lostReason() noexcept { return (m_ == nullptr) ? "not added to an interface" : urb_manager_lost_reason(m_); }
    /** The C manager (nullptr before addBusManager). */
    urb_manager_t *cmanager() noexcept { return m_; }

protected:
    BusManager(const char *path, const urb_core_config_t *cfg) noexcept
    {
        (void)std::snprintf(path_, sizeof path_, "%s", (path == nullptr) ? "" : path);
        if (cfg != nullptr) {
            cfg_ = *cfg;
            haveCfg_ = true;
        }
    }
    virtual int32_t open(urb_loop_t *loop, char *err, size_t n) noexcept = 0;

    friend class URBInterface;
    char path_[URB_PATH_MAX];
    urb_core_config_t cfg_{};
    bool haveCfg_ = false;
    urb_manager_t *m_ = nullptr;
};

/** A bridge on a serial port (the paper's RS232Manager). */
class RS232Manager : public BusManager {
public:
    explicit RS232Manager(const char *port, uint32_t baud = 115200, const urb_core_config_t *cfg = nullptr) noexcept
        : BusManager(port, cfg), baud_(baud)
    {
    }

private:
    int32_t open(urb_loop_t *loop, char *err, size_t n) noexcept override
    {
        return urb_loop_add_rs232(loop, path_, baud_, haveCfg_ ? &cfg_ : nullptr, &m_, err, n);
    }
    uint32_t baud_;
};

/** A bridge on USB (the paper's USBManager): its transfer device, or a descriptor that keeps
 *  transfer boundaries (fd >= 0: the caller's, e.g. a SOCK_SEQPACKET socket; name names it). */
class USBManager : public BusManager {
public:
    explicit USBManager(const char *device, const urb_core_config_t *cfg = nullptr) noexcept : BusManager(device, cfg) {}
    USBManager(int fd, const char *name, const urb_core_config_t *cfg = nullptr) noexcept : BusManager(name, cfg), fd_(fd)
    {
    }

private:
    int32_t open(urb_loop_t *loop, char *err, size_t n) noexcept override
    {
        if (fd_ >= 0) {
            int32_t const rc = urb_loop_add_usb_fd(loop, fd_, path_, haveCfg_ ? &cfg_ : nullptr, &m_);
            if (rc != URB_HOST_OK) {
                (void)std::snprintf(err, n, "%s: cannot add the USB descriptor (%s)", path_, urb_host_error_name(rc));
            }
            return rc;
        }
        return urb_loop_add_usb(loop, path_, haveCfg_ ? &cfg_ : nullptr, &m_, err, n);
    }
    int fd_ = -1;
};

// -------------------------------------------------------------------------------------------
/** The entry point (the paper's singleton URBInterface): bridges, discovery, nodes, the loop. */
class URBInterface {
public:
    /** The process-wide interface, made on first use (the default schema). nullptr only when its
     *  memory could not be had. Destroyed at exit (closing every bridge). */
    static URBInterface *instance() noexcept
    {
        static URBInterface one;
        return one.ok() ? &one : nullptr;
    }

    /** An interface of its own (tests, several systems in one process): `schema` nullptr is the
     *  default. ok() is false when its memory could not be had. */
    explicit URBInterface(const urb_schema_t *schema = nullptr) noexcept
    {
        loop_.reset(new (std::nothrow) urb_loop_t);
        if (loop_ && (urb_loop_init(loop_.get(), schema) != URB_HOST_OK)) {
            loop_.reset();
        }
        say(loop_ ? "" : "could not allocate or initialise the URB loop (memory or file descriptors)");
    }
    ~URBInterface()
    {
        if (!loop_) {
            return;
        }
        (void)urb_loop_stop_thread(loop_.get());
        for (size_t i = 0; i < count_; i++) {
            (void)urb_loop_close_manager(loop_.get(), managers_[i]->m_, true);
        }
        urb_loop_destroy(loop_.get());
    }
    URBInterface(const URBInterface &) = delete;
    URBInterface &operator=(const URBInterface &) = delete;

    bool ok() const noexcept { return static_cast<bool>(loop_); }
    /** What the last failed call found, and what to do. */
    const char *lastError() const noexcept { return error_; }

    /** Requests in each node's pool, for accessors made from now on (default 32). */
    void setPoolSize(size_t n) noexcept { pool_ = n; }

    /**
     * Registers a bridge: takes ownership of `m` (also on failure), opens its uplink and discovers
     * its downlink, waiting up to timeoutNs. Returns URB_HOST_OK, or the code of the step that
     * failed with lastError() saying why (no such port, no bridge answering, ...).
     */
    int32_t addBusManager(BusManager *m, bool rescan = true, int64_t timeoutNs = 3 * URB_NS_PER_S) noexcept
    {
        std::unique_ptr<BusManager> own(m);
        if (!ok() || (m == nullptr) || (count_ >= URB_LOOP_MAX_MANAGERS)) {
            say((m == nullptr) ? "addBusManager(nullptr)" : "no room for another bridge (URB_LOOP_MAX_MANAGERS)");
            return URB_HOST_EINVAL;
        }
        int32_t rc = m->open(loop_.get(), error_, sizeof error_);
        if (rc != URB_HOST_OK) {
            return rc;
        }
        managers_[count_++] = std::move(own);
        return urb_loop_discover(loop_.get(), m->m_, rescan, timeoutNs, error_, sizeof error_);
    }

    /** The node of class `classId` (e.g. URB_NODE_MOTOR_DRIVER_CLASS) and `index`: nullptr with
     *  lastError() when it is not discovered, answers twice, or was built from another schema. The
     *  same node gives the same accessor. */
    NodeAccessor *findNode(uint8_t classId, uint8_t index) noexcept
    {
        urb_node_t n;
        if (!ok() || (urb_loop_find_node(loop_.get(), classId, index, &n, error_, sizeof error_) != URB_HOST_OK)) {
            return nullptr;
        }
        return accessor(n);
    }

    /** findNode by the schema's name ("MotorDriver", any case). */
    NodeAccessor *findNode(const char *className, uint8_t index) noexcept
    {
        const urb_node_type_t *t = ok() ? urb_schema_find_name(loop_->system.schema, className) : nullptr;
        if (t == nullptr) {
            (void)std::snprintf(error_, sizeof error_, "no node type named '%s' in the host's schema",
                                (className == nullptr) ? "" : className);
            return nullptr;
        }
        return findNode(t->class_id, index);
    }

    /** Whatever answered at `address` of `m`'s bridge (0: the bridge itself), flags or not; a node
     *  the schema does not describe gets its own reported mailbox sizes. nullptr when none did. */
    NodeAccessor *nodeAt(BusManager *m, uint8_t address) noexcept
    {
        urb_node_t n;
        if (!ok() || (m == nullptr) || (urb_loop_node_at(loop_.get(), m->m_, address, &n) != URB_HOST_OK)) {
            say("no node answered at that address (rediscover, or check the address)");
            return nullptr;
        }
        return accessor(n);
    }

    /** The loop's descriptor to poll, and when to call runOnce without input (urb_loop.h). */
    int fd() const noexcept { return ok() ? urb_loop_fd(loop_.get()) : -1; }
    int64_t nextDeadline() noexcept { return ok() ? urb_loop_next_deadline(loop_.get()) : URB_NEVER; }
    /** Does what is due after waiting at most timeoutNs for input or the next deadline (0: after
     *  polling fd(), which it then arms; urb_loop_run_once); the number of callbacks run, or < 0. */
    int32_t runOnce(int64_t timeoutNs) noexcept { return ok() ? urb_loop_run_once(loop_.get(), timeoutNs) : URB_HOST_EINVAL; }
    /** A cyclic program's call once per period, after sleeping to its tick (urb_sleep_until): does
     *  what came and what is due without waiting (urb_loop_service; its latency trade-off in
     *  urb_loop.h); the number of callbacks run, or < 0. */
    int32_t service() noexcept { return ok() ? urb_loop_service(loop_.get()) : URB_HOST_EINVAL; }
    /** Runs the loop on a thread of its own (callbacks run there). */
    int32_t startThread() noexcept { return ok() ? urb_loop_start_thread(loop_.get()) : URB_HOST_EINVAL; }
    int32_t stopThread() noexcept { return ok() ? urb_loop_stop_thread(loop_.get()) : URB_HOST_EINVAL; }
    /** Told once per loss that a bridge went away (before the failed requests' callbacks). */
    void setLostCallback(urb_lost_fn fn, void *user = nullptr) noexcept
    {
        if (ok()) {
            urb_loop_set_lost_callback(loop_.get(), fn, user);
        }
    }
    /** The C loop underneath. */
    urb_loop_t *cloop() noexcept { return loop_.get(); }

private:
    void say(const char *text) noexcept { (void)std::snprintf(error_, sizeof error_, "%s", text); }

    NodeAccessor *accessor(const urb_node_t &n) noexcept
    {
        size_t const key = n.bridge ? URB_SYSTEM_MAX_ROWS + n.manager : n.row;
        std::unique_ptr<NodeAccessor> &slot = n.own_layout ? raw_[key] : nodes_[key];
        if (!slot) {
            slot.reset(new (std::nothrow) NodeAccessor());
            if (!slot || !slot->init(n, pool_)) {
                slot.reset();
                say("could not allocate the node's request pool");
                return nullptr;
            }
        }
        return slot.get();
    }

    std::unique_ptr<urb_loop_t> loop_;
    std::unique_ptr<BusManager> managers_[URB_LOOP_MAX_MANAGERS];
    size_t count_ = 0;
    std::unique_ptr<NodeAccessor> nodes_[URB_SYSTEM_MAX_ROWS + URB_LOOP_MAX_MANAGERS];
    std::unique_ptr<NodeAccessor> raw_[URB_SYSTEM_MAX_ROWS + URB_LOOP_MAX_MANAGERS];
    size_t pool_ = 32;
    char error_[1024] = "";
};

}  // namespace urb

#endif  // URB_HPP

/*
 * Opening a serial port for URB (settings and why: urb_port.h) and the USB transfer device, with
 * the Python library's failure messages (host/urb/managers/rs232.py, usb.py).
 */
#include "urb_port.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/serial.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#define PORTS "serial ports are usually /dev/ttyS*, /dev/ttyUSB* or /dev/ttyACM* (`ls /dev/tty[SUA]*`)"

urb_ns_t urb_now_ns(void)
{
    struct timespec ts;
    (void)clock_gettime(CLOCK_MONOTONIC, &ts);
    return (urb_ns_t)ts.tv_sec * URB_NS_PER_S + (urb_ns_t)ts.tv_nsec;
}

void urb_sleep_until(urb_ns_t when)
{
    if (when <= 0) {
        return;
    }
    struct timespec const ts = {(time_t)(when / URB_NS_PER_S), (long)(when % URB_NS_PER_S)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
        /* a signal: sleep on until `when` (an absolute time: nothing to recompute) */
    }
}

static void say(char *err, size_t size, const char *fmt, const char *a, const char *b)
{
    if ((err != NULL) && (size > 0u)) {
        (void)snprintf(err, size, fmt, a, b, a);
    }
}

/* The explanation of a failed open (rs232.port_error_message), for errno `code`. */
static void port_error(const char *path, int code, char *err, size_t size)
{
    struct stat st;
    bool const is_file = (stat(path, &st) == 0) && S_ISREG(st.st_mode);
    bool const is_dir = (stat(path, &st) == 0) && S_ISDIR(st.st_mode);
    if (code == ENOENT) {
        say(err, size, "%s: no such port. Check the path and the cable; %s.", path, PORTS);
    } else if ((code == EISDIR) || is_dir) {
        say(err, size, "%s: is a directory, not a serial port. Give the bridge's device; %s.", path, PORTS);
    } else if (code == ENOTTY) {
        char text[64];
        (void)snprintf(text, sizeof text, "%s", is_file ? "a regular file" : "a device that is not a terminal");
        if ((err != NULL) && (size > 0u)) {
            (void)snprintf(err, size, "%s: not a serial port (%s). Give the bridge's device; %s.", path, text, PORTS);
        }
    } else if ((code == EACCES) || (code == EPERM)) {
        const char *user = getenv("USER");
        if ((err != NULL) && (size > 0u)) {
            (void)snprintf(err, size,
                           "%s: permission denied. Add yourself to the group owning the port (`ls -l %s`; usually: "
                           "sudo usermod -aG dialout %s) and log in again.",
                           path, path, (user == NULL) ? "$USER" : user);
        }
    } else if ((code == EBUSY) || (code == EWOULDBLOCK)) {
        say(err, size, "%s: the port is in use by another program (close it, or find it with `fuser %s`).", path, path);
    } else if ((err != NULL) && (size > 0u)) {
        (void)snprintf(err, size, "%s: cannot open the port: %s.", path, strerror(code));
    }
}

static speed_t speed_of(uint32_t baud)
{
    switch (baud) {
    case 1200u: return B1200;
    case 2400u: return B2400;
    case 4800u: return B4800;
    case 9600u: return B9600;
    case 19200u: return B19200;
    case 38400u: return B38400;
    case 57600u: return B57600;
    case 115200u: return B115200;
    case 230400u: return B230400;
    case 460800u: return B460800;
    case 500000u: return B500000;
    case 576000u: return B576000;
    case 921600u: return B921600;
    case 1000000u: return B1000000;
    case 1152000u: return B1152000;
    case 1500000u: return B1500000;
    case 2000000u: return B2000000;
    case 2500000u: return B2500000;
    case 3000000u: return B3000000;
    case 3500000u: return B3500000;
    case 4000000u: return B4000000;
    default: return B0;
    }
}

/* Sets ASYNC_LOW_LATENCY when the driver has it; false when it refuses (a pty, many adapters). */
static bool set_low_latency(int fd)
{
    struct serial_struct ss;
    if (ioctl(fd, TIOCGSERIAL, &ss) != 0) {
        return false;
    }
    ss.flags = (int)((unsigned int)ss.flags | (unsigned int)ASYNC_LOW_LATENCY);
    return ioctl(fd, TIOCSSERIAL, &ss) == 0;
}

int32_t urb_serial_open(const char *path, uint32_t baud, int *fd_out, bool *low_latency, char *err,
                        size_t err_size)
{
    if ((path == NULL) || (fd_out == NULL)) {
        return URB_HOST_EINVAL;
    }
    speed_t const speed = speed_of(baud);
    if (speed == B0) {
        if ((err != NULL) && (err_size > 0u)) {
            (void)snprintf(err, err_size, "%s: invalid serial setting (baud rate %lu is not a standard rate); check --baud.",
                           path, (unsigned long)baud);
        }
        return URB_HOST_EINVAL;
    }
    int const fd = open(path, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        port_error(path, errno, err, err_size);
        return URB_HOST_EIO;
    }
    struct termios tio;
    int code = 0;
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) { /* one process per port, as pyserial's exclusive=True */
        code = errno;
    } else if (tcgetattr(fd, &tio) != 0) {
        code = errno;
    } else {
        cfmakeraw(&tio); /* 8 data bits, no echo, no line editing, no translation, no signals */
        tio.c_cflag |= (tcflag_t)(CLOCAL | CREAD);
        tio.c_cflag &= (tcflag_t) ~(PARENB | CSTOPB | CRTSCTS);
        tio.c_iflag &= (tcflag_t) ~(IXON | IXOFF | IXANY);
        tio.c_cc[VMIN] = 1u;
        tio.c_cc[VTIME] = 0u;
        if ((cfsetispeed(&tio, speed) != 0) || (cfsetospeed(&tio, speed) != 0) || (tcsetattr(fd, TCSANOW, &tio) != 0)) {
            code = errno;
        }
    }
    if (code != 0) {
        (void)close(fd);
        port_error(path, code, err, err_size);
        return URB_HOST_EIO;
    }
    bool const low = set_low_latency(fd);
    if (low_latency != NULL) {
        *low_latency = low;
    }
    (void)tcflush(fd, TCIFLUSH); /* a previous user's bytes */
    *fd_out = fd;
    return URB_HOST_OK;
}

void urb_serial_close(int fd)
{
    if (fd >= 0) {
        (void)close(fd);
    }
}

int32_t urb_usbdev_open(const char *path, int *fd_out, char *err, size_t err_size)
{
    if ((path == NULL) || (fd_out == NULL)) {
        return URB_HOST_EINVAL;
    }
    int const fd = open(path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        if ((err != NULL) && (err_size > 0u)) {
            (void)snprintf(err, err_size,
                           "%s: cannot open the USB bridge device (%s); check the kernel driver is loaded and the device "
                           "permissions",
                           path, strerror(errno));
        }
        return URB_HOST_EIO;
    }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) { /* one user at a time */
        (void)close(fd);
        say(err, err_size, "%s: the USB bridge is in use by another program (close it, or find it with `fuser %s`).", path,
            path);
        return URB_HOST_EIO;
    }
    *fd_out = fd;
    return URB_HOST_OK;
}

/*
 * The node types of the generated schemas (gen/c/urb_sensorhex.h, urb_core.h) as a table the
 * discovery matches identifications against (the Python library's urb_msgs.NODES).
 */
#include "urb_discovery.h"

#include <ctype.h>
#include <stddef.h>

#include "urb_sensorhex.h"

#define SENSORHEX "spec/schema/sensorhex.urbs"

static const urb_node_type_t sensorhex_types[] = {
    {"MotorDriver", URB_NODE_MOTOR_DRIVER_CLASS, URB_NODE_MOTOR_DRIVER_FINGERPRINT,
     {URB_NODE_MOTOR_DRIVER_INBOX0_SIZE, URB_NODE_MOTOR_DRIVER_INBOX1_SIZE, URB_NODE_MOTOR_DRIVER_INBOX2_SIZE, 0u, 0u,
      0u, 0u, 0u},
     {URB_NODE_MOTOR_DRIVER_OUTBOX0_SIZE, URB_NODE_MOTOR_DRIVER_OUTBOX1_SIZE, URB_NODE_MOTOR_DRIVER_OUTBOX2_SIZE, 0u,
      0u, 0u, 0u, 0u},
     SENSORHEX},
    {"BatteryManager", URB_NODE_BATTERY_MANAGER_CLASS, URB_NODE_BATTERY_MANAGER_FINGERPRINT,
     {URB_NODE_BATTERY_MANAGER_INBOX0_SIZE, 0u, 0u, 0u, 0u, 0u, 0u, 0u},
     {URB_NODE_BATTERY_MANAGER_OUTBOX0_SIZE, URB_NODE_BATTERY_MANAGER_OUTBOX1_SIZE, 0u, 0u, 0u, 0u, 0u, 0u},
     SENSORHEX},
    {"Imu", URB_NODE_IMU_CLASS, URB_NODE_IMU_FINGERPRINT, {URB_NODE_IMU_INBOX0_SIZE, 0u, 0u, 0u, 0u, 0u, 0u, 0u},
     {URB_NODE_IMU_OUTBOX0_SIZE, URB_NODE_IMU_OUTBOX1_SIZE, 0u, 0u, 0u, 0u, 0u, 0u}, SENSORHEX},
    {"IrDistance", URB_NODE_IR_DISTANCE_CLASS, URB_NODE_IR_DISTANCE_FINGERPRINT,
     {URB_NODE_IR_DISTANCE_INBOX0_SIZE, 0u, 0u, 0u, 0u, 0u, 0u, 0u},
     {URB_NODE_IR_DISTANCE_OUTBOX0_SIZE, URB_NODE_IR_DISTANCE_OUTBOX1_SIZE, 0u, 0u, 0u, 0u, 0u, 0u}, SENSORHEX},
};

static const urb_schema_t sensorhex_schema = {sensorhex_types, sizeof sensorhex_types / sizeof sensorhex_types[0]};

static const urb_node_type_t bridge_type = {
    "Bridge", URB_NODE_BRIDGE_CLASS, URB_NODE_BRIDGE_FINGERPRINT,
    {URB_NODE_BRIDGE_INBOX0_SIZE, 0u, 0u, 0u, 0u, 0u, 0u, 0u},
    {URB_NODE_BRIDGE_OUTBOX0_SIZE, URB_NODE_BRIDGE_OUTBOX1_SIZE, 0u, 0u, 0u, 0u, 0u, 0u},
    "spec/schema/core.urbs"};

const urb_schema_t *urb_schema_default(void) { return &sensorhex_schema; }

const urb_node_type_t *urb_schema_bridge(void) { return &bridge_type; }

const urb_node_type_t *urb_schema_find_class(const urb_schema_t *schema, uint8_t class_id)
{
    if (schema == NULL) {
        return NULL;
    }
    for (size_t i = 0u; i < schema->count; i++) {
        if (schema->types[i].class_id == class_id) {
            return &schema->types[i];
        }
    }
    return NULL;
}

static bool same_name(const char *a, const char *b)
{
    while ((*a != '\0') && (*b != '\0')) {
        if (tolower((unsigned char)*a) != tolower((unsigned char)*b)) {
            return false;
        }
        a++;
        b++;
    }
    return *a == *b;
}

const urb_node_type_t *urb_schema_find_name(const urb_schema_t *schema, const char *name)
{
    if ((schema == NULL) || (name == NULL)) {
        return NULL;
    }
    for (size_t i = 0u; i < schema->count; i++) {
        if (same_name(schema->types[i].name, name)) {
            return &schema->types[i];
        }
    }
    return NULL;
}

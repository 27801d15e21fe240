// onomato -> Unity, with OscJack (https://github.com/keijiro/OscJack).
// Put this on a ball. It listens on a UDP port for onomato's OSC and moves the ball up
// and down so that it lands exactly on each hit:
//   - with "/onomato/bounce/state" (set [osc] bounce_state_rate in onomato's config),
//     the height comes from onomato's live bounce solver directly;
//   - otherwise it flies ballistically from each "/onomato/bounce/hit" (launch velocity,
//     gravity), which lands it at the predicted time of the next hit.
// Run onomato with:  onomato listen --config my.toml --bounce --osc <this machine>:9000
// OscJack calls back on its own thread: the callbacks only store values, and Update()
// applies them on Unity's main thread.
using UnityEngine;
using OscJack;

public class OnomatoBall : MonoBehaviour
{
    public int port = 9000;
    public float gravity = 9.81f;      // the same as onomato's [bounce] gravity
    public float floorY = 0f;
    public bool useStateStream = true; // use /onomato/bounce/state when it arrives

    OscServer _server;
    readonly object _lock = new object();
    bool _newHit;
    float _launchVelocity;
    bool _hasState;
    float _stateHeight;

    float _height;
    float _velocity;

    void Start()
    {
        _server = new OscServer(port);
        // f launch velocity, f launch time, f predicted landing, f apex, f squash, i id
        _server.MessageDispatcher.AddCallback("/onomato/bounce/hit",
            (string address, OscDataHandle data) =>
            {
                lock (_lock) { _launchVelocity = data.GetElementAsFloat(0); _newHit = true; }
            });
        // f height, f velocity, f time
        _server.MessageDispatcher.AddCallback("/onomato/bounce/state",
            (string address, OscDataHandle data) =>
            {
                lock (_lock) { _stateHeight = data.GetElementAsFloat(0); _hasState = true; }
            });
        // f strength, f time, i id, then the time exactly as i seconds, f fraction: one
        // message per "tick" (use your pattern names).
        _server.MessageDispatcher.AddCallback("/onomato/tick",
            (string address, OscDataHandle data) =>
            {
                double time = data.GetElementAsInt(3) + (double)data.GetElementAsFloat(4);
                Debug.Log($"tick: strength {data.GetElementAsFloat(0)} at {time:F3} s");
            });
    }

    void Update()
    {
        bool hit, state;
        float v, h;
        lock (_lock)
        {
            hit = _newHit; _newHit = false; v = _launchVelocity;
            state = _hasState; h = _stateHeight;
        }
        if (useStateStream && state)
        {
            _height = h;
        }
        else
        {
            if (hit) { _height = 0f; _velocity = v; }
            float dt = Time.deltaTime;
            _height += _velocity * dt - 0.5f * gravity * dt * dt;
            _velocity -= gravity * dt;
            if (_height <= 0f) { _height = 0f; _velocity = 0f; } // waits on the floor
        }
        var p = transform.position;
        transform.position = new Vector3(p.x, floorY + _height, p.z);
    }

    void OnDestroy()
    {
        _server?.Dispose();
        _server = null;
    }
}
